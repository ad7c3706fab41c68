/**
 * @file discretizations.cpp
 * The catalogue of discretizations (discretizations.hpp): the table with one row per family, the
 * checks of each family's parameter, and what is derived from the rows (canonical names, the
 * lists of valid names, the default discretization of each model order).
 */
#include "pardel_codegen/discretizations.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace pardel_codegen {
namespace {

std::string rational_text(const GiNaC::numeric& n) {
  std::ostringstream s;
  s << n;
  return s.str();
}

/** A rational as part of a C identifier: "-1/3" is "m1_3". */
std::string rational_ident(const GiNaC::numeric& n) {
  std::string out;
  for (char c : rational_text(n)) {
    if (c == '-') out += 'm';
    else if (c == '/') out += '_';
    else out += c;
  }
  return out;
}

bool is_integer_in(const GiNaC::ex& value, int low, int high) {
  if (!GiNaC::is_a<GiNaC::numeric>(value)) return false;
  const GiNaC::numeric& n = GiNaC::ex_to<GiNaC::numeric>(value);
  return n.is_integer() && n >= low && n <= high;
}

// The parameters' checks.

std::string alpha_refusal(const std::string&, const GiNaC::ex& value, int) {
  if (GiNaC::is_a<GiNaC::numeric>(value) && GiNaC::ex_to<GiNaC::numeric>(value).is_rational()) return {};
  return "alpha must be a rational number such as 1, 1/2 or 0.25";
}

std::string hermite_points_refusal(const std::string& name, const GiNaC::ex& value, int order) {
  if (!is_integer_in(value, 1, kMaxDiscretizationPoints)) {
    return "s (the number of Gauss points) must be an integer from 1 to " + std::to_string(kMaxDiscretizationPoints);
  }
  const int s = GiNaC::ex_to<GiNaC::numeric>(value).to_int();
  if (s >= order) return {};
  return name + "(s=" + std::to_string(s) + ") is not regular for an order-" + std::to_string(order) +
         " model: the interpolant's derivative of order " + std::to_string(order) + " is a polynomial of degree " +
         std::to_string(order - 1) + " that can vanish at all " + std::to_string(s) +
         " Gauss points (s must be at least " + std::to_string(order) + ")";
}

std::string galerkin_points_refusal(const std::string& name, const GiNaC::ex& value, int order) {
  if (is_integer_in(value, order, kMaxDiscretizationPoints)) return {};
  return "s of " + name + " must be an integer from " + std::to_string(order) + " (the model's order) to " +
         std::to_string(kMaxDiscretizationPoints) + "; the consistency order is 2 s";
}

const char* alpha_never_regular(const DiscretizationSpec& spec) {
  if (!spec.alpha.is_zero()) return nullptr;
  return "with alpha = 0 the accelerations a0 = a1 = (v1 - v0)/h do not involve the positions x0, x1, so "
         "d2Ld/dx0dx1 = 0 for every L (D12 Ld is singular) and the DEL equations do not determine the positions; "
         "use alpha != 0 (trapezoid(alpha=1) is the default) or gauss2";
}

Quadrature lobatto_rule(int s) { return gauss_lobatto(s + 1); }

// The parameters.

DiscretizationParameter alpha_parameter() {
  DiscretizationParameter p;
  p.kind = ParameterKind::rational;
  p.key = "alpha";
  p.placeholder = "A";
  p.expected = "alpha";
  p.default_value = 1;
  p.refusal = alpha_refusal;
  return p;
}

DiscretizationParameter hermite_points() {
  DiscretizationParameter p;
  p.kind = ParameterKind::integer;
  p.key = "s";
  p.placeholder = "S";
  p.expected = "s, the number of Gauss points";
  p.default_is_order = true;
  p.refusal = hermite_points_refusal;
  return p;
}

DiscretizationParameter galerkin_points() {
  DiscretizationParameter p;
  p.kind = ParameterKind::integer;
  p.key = "s";
  p.placeholder = "S";
  p.expected = "s, half the consistency order";
  p.required = true;
  p.example = "4";
  p.meaning = "consistency order 2 s";
  p.refusal = galerkin_points_refusal;
  return p;
}

/** A row: the fields every family has; the rest is set by the table below. */
DiscretizationFamily row(const char* name, int min_order, int max_order, int (*consistency)(int, int),
                         DiscreteLagrangianBuilder build) {
  DiscretizationFamily f;
  f.name = name;
  f.min_order = min_order;
  f.max_order = max_order;
  f.consistency_order = consistency;
  f.build = build;
  return f;
}

std::vector<DiscretizationFamily> make_catalogue() {
  std::vector<DiscretizationFamily> rows;
  DiscretizationFamily f = row("trapezoid", 1, 1, [](int, int) { return 2; }, trapezoid_lagrangian);
  f.default_min_order = f.default_max_order = 1;
  rows.push_back(f);
  rows.push_back(row("midpoint", 1, 1, [](int, int) { return 2; }, midpoint_lagrangian));
  f = row("trapezoid", 2, 2, [](int, int) { return 2; }, trapezoid_alpha_lagrangian);
  f.parameter = alpha_parameter();
  f.default_min_order = f.default_max_order = 2;
  f.never_regular = alpha_never_regular;
  rows.push_back(f);
  rows.push_back(row("gauss2", 2, 2, [](int, int) { return 4; }, gauss2_lagrangian));
  f = row("hermite_gauss", 1, 0, [](int order, int s) { return 2 * std::min(order, s); }, hermite_gauss_lagrangian);
  f.parameter = hermite_points();
  f.default_min_order = 3;
  rows.push_back(f);
  for (const char* name : {"galerkin_gauss", "galerkin_lobatto"}) {
    f = row(name, 1, 0, [](int, int s) { return 2 * s; }, galerkin_lagrangian);
    f.parameter = galerkin_points();
    f.interior_values = true;
    f.quadrature = name == std::string("galerkin_gauss") ? gauss_legendre : lobatto_rule;
    rows.push_back(f);
  }
  return rows;
}

}  // namespace

std::string DiscretizationFamily::shown() const {
  if (parameter.kind == ParameterKind::none) return name;
  return std::string(name) + "(" + parameter.key + "=" + parameter.placeholder + ")";
}

const std::vector<DiscretizationFamily>& discretization_catalogue() {
  static const std::vector<DiscretizationFamily> catalogue = make_catalogue();
  return catalogue;
}

const DiscretizationFamily* find_discretization_family(const std::string& name, int order) {
  for (const DiscretizationFamily& f : discretization_catalogue()) {
    if (name == f.name && f.valid_for(order)) return &f;
  }
  return nullptr;
}

const DiscretizationFamily* parameterized_discretization_family(const std::string& name) {
  for (const DiscretizationFamily& f : discretization_catalogue()) {
    if (name == f.name && f.parameter.kind != ParameterKind::none) return &f;
  }
  return nullptr;
}

bool is_discretization_name(const std::string& name) {
  const std::vector<DiscretizationFamily>& rows = discretization_catalogue();
  return std::any_of(rows.begin(), rows.end(), [&](const DiscretizationFamily& f) { return name == f.name; });
}

std::string discretization_names(int order) {
  std::string out;
  for (const DiscretizationFamily& f : discretization_catalogue()) {
    if (f.valid_for(order)) out += (out.empty() ? "" : ", ") + f.shown();
  }
  return out;
}

DiscretizationSpec make_discretization_spec(const DiscretizationFamily& family, int order, const GiNaC::numeric& value) {
  DiscretizationSpec spec;
  spec.family = &family;
  const DiscretizationParameter& p = family.parameter;
  std::string text, ident;
  if (p.kind == ParameterKind::rational) {
    spec.alpha = value;
    text = rational_text(value);
    ident = rational_ident(value);
  } else if (p.kind == ParameterKind::integer) {
    spec.stages = value.to_int();
    if (family.interior_values) spec.interior_points = spec.stages - order;
    text = ident = std::to_string(spec.stages);
  }
  spec.name = spec.ident = family.name;
  if (p.kind != ParameterKind::none) {
    spec.name += std::string("(") + p.key + "=" + text + ")";
    spec.ident += std::string("_") + p.key + "_" + ident;
  }
  spec.consistency_order = family.consistency_order(order, spec.stages);
  if (p.kind == ParameterKind::none || (!p.required && value == default_parameter(family, order)))
    spec.bare_name = family.name;
  return spec;
}

GiNaC::numeric default_parameter(const DiscretizationFamily& family, int order) {
  return family.parameter.default_is_order ? GiNaC::numeric(order) : GiNaC::numeric(family.parameter.default_value);
}

DiscretizationSpec default_discretization(int order) {
  for (const DiscretizationFamily& f : discretization_catalogue()) {
    if (f.default_for(order) && f.valid_for(order)) return make_discretization_spec(f, order, default_parameter(f, order));
  }
  throw std::logic_error("no default discretization for order " + std::to_string(order));
}

}  // namespace pardel_codegen

/**
 * @file lag_discretizations.cpp
 * The 'discretizations' line of the .lag reader: the names of the discrete Lagrangians to
 * generate, with their parameters (trapezoid(alpha=A), hermite_gauss(s=S), galerkin_*(s=S)),
 * checked against the model's order and turned into canonical DiscretizationSpecs.
 */
#include <algorithm>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "lag_reader.hpp"

namespace pardel_codegen::lag {
namespace {

std::string rational_text(const GiNaC::numeric& n) {
  std::ostringstream s;
  s << n;
  return s.str();
}

/** The largest number of Gauss points hermite_gauss accepts. */
constexpr int kMaxGaussPoints = 16;

/** galerkin_gauss(s=S) or galerkin_lobatto(s=S) for an order-`order` model (S >= order): the
 *  polynomial of degree S + order - 1 through both nodes' jets and S - order interior values,
 *  consistency order 2 S. */
DiscretizationSpec galerkin_spec(DiscretizationKind kind, int order, int stages) {
  DiscretizationSpec spec;
  spec.kind = kind;
  spec.stages = stages;
  spec.interior_points = stages - order;
  const std::string family = kind == DiscretizationKind::galerkin_gauss ? "galerkin_gauss" : "galerkin_lobatto";
  spec.name = family + "(s=" + std::to_string(stages) + ")";
  spec.ident = family + "_s_" + std::to_string(stages);
  spec.consistency_order = 2 * stages;
  return spec;
}

std::string rational_ident(const GiNaC::numeric& n) {
  std::string out;
  for (char c : rational_text(n)) {
    if (c == '-') out += 'm';
    else if (c == '/') out += '_';
    else out += c;
  }
  return out;
}

}  // namespace

/** hermite_gauss(s=S) for an order-`order` model (S >= order): consistency order min(2 order, 2 S). */
DiscretizationSpec hermite_gauss_spec(int order, int stages) {
  DiscretizationSpec spec;
  spec.kind = DiscretizationKind::hermite_gauss;
  spec.stages = stages;
  spec.name = "hermite_gauss(s=" + std::to_string(stages) + ")";
  spec.ident = "hermite_gauss_s_" + std::to_string(stages);
  spec.consistency_order = 2 * std::min(order, stages);
  return spec;
}

void Reader::read_discretizations(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  std::map<std::string, int> seen;
  const std::string galerkin = ", galerkin_gauss(s=S), galerkin_lobatto(s=S)";
  const std::string available = (model_.order == 1   ? "trapezoid, midpoint, hermite_gauss(s=S)"
                                 : model_.order == 2 ? "trapezoid(alpha=A), gauss2, hermite_gauss(s=S)"
                                                     : "hermite_gauss(s=S)") +
                                galerkin;
  std::size_t i = 1;
  while (toks[i].kind != Tok::end) {
    if (toks[i].kind == Tok::op && toks[i].text == ",") {
      ++i;
      continue;
    }
    const Token& name = toks[i];
    if (name.kind != Tok::ident || name.primes > 0) {
      fail(line, name, "expected a discretization name, found " + name.shown());
    }
    ++i;
    bool has_value = false;
    GiNaC::numeric value = 1;
    int value_col = name.col;
    if (toks[i].kind == Tok::op && toks[i].text == "(") {
      value = read_discretization_parameter(line, name, i, value_col);
      has_value = true;
    }
    DiscretizationSpec spec = discretization_spec(line, name, has_value, value, value_col, available);
    auto it = seen.find(spec.name);
    if (it != seen.end()) {
      fail(line, name, "duplicate discretization '" + spec.name + "'");
    }
    seen[spec.name] = name.col;
    model_.discretizations.push_back(spec);
  }
}

/**
 * The parameter of a discretization, `(alpha=A)` or `(s=S)`, from the '(' at `i`; leaves `i` after
 * the ')' and `value_col` at the value's column.
 */
GiNaC::numeric Reader::read_discretization_parameter(const Line& line, const Token& name, std::size_t& i,
                                                     int& value_col) const {
  const std::vector<Token>& toks = line.tokens;
  ++i;
  const Token& key = toks[i];
  if (key.kind != Tok::ident || key.primes > 0) {
    fail(line, key, "expected a parameter name such as alpha, found " + key.shown());
  }
  const bool trapezoid = name.text == "trapezoid", hermite = name.text == "hermite_gauss";
  const bool galerkin_name = name.text == "galerkin_gauss" || name.text == "galerkin_lobatto";
  if (!(trapezoid && key.text == "alpha") && !((hermite || galerkin_name) && key.text == "s")) {
    if (trapezoid) fail(line, key, "unknown parameter '" + key.text + "' of trapezoid (expected alpha)");
    if (hermite) fail(line, key, "unknown parameter '" + key.text + "' of hermite_gauss (expected s, the number of Gauss points)");
    if (galerkin_name)
      fail(line, key, "unknown parameter '" + key.text + "' of " + name.text + " (expected s, half the consistency order)");
    fail(line, key, "'" + name.text + "' takes no parameters");
  }
  ++i;
  if (!(toks[i].kind == Tok::op && toks[i].text == "=")) {
    fail(line, toks[i], "expected '=' after " + key.text + ", found " + toks[i].shown());
  }
  ++i;
  value_col = toks[i].col;
  // The value: an optionally signed rational number, up to the closing parenthesis.
  Cursor c{&line, i};
  ExprContext ctx;
  ctx.scope = Scope::constant;
  GiNaC::ex parsed = parse_sum(c, ctx);
  if (!c.at_op(')')) fail(line, c.peek(), "expected ')' after the value of " + key.text + ", found " + c.peek().shown());
  i = c.pos + 1;
  if (!GiNaC::is_a<GiNaC::numeric>(parsed) || !GiNaC::ex_to<GiNaC::numeric>(parsed).is_rational()) {
    if (trapezoid) fail(line.number, value_col, "alpha must be a rational number such as 1, 1/2 or 0.25");
  }
  if (hermite && (!GiNaC::is_a<GiNaC::numeric>(parsed) || !GiNaC::ex_to<GiNaC::numeric>(parsed).is_integer() ||
                  GiNaC::ex_to<GiNaC::numeric>(parsed) < 1 || GiNaC::ex_to<GiNaC::numeric>(parsed) > kMaxGaussPoints)) {
    fail(line.number, value_col,
         "s (the number of Gauss points) must be an integer from 1 to " + std::to_string(kMaxGaussPoints));
  }
  if (galerkin_name && (!GiNaC::is_a<GiNaC::numeric>(parsed) || !GiNaC::ex_to<GiNaC::numeric>(parsed).is_integer() ||
                        GiNaC::ex_to<GiNaC::numeric>(parsed) < model_.order ||
                        GiNaC::ex_to<GiNaC::numeric>(parsed) > kMaxGaussPoints)) {
    fail(line.number, value_col,
         "s of " + name.text + " must be an integer from " + std::to_string(model_.order) + " (the model's order) to " +
             std::to_string(kMaxGaussPoints) + "; the consistency order is 2 s");
  }
  return GiNaC::ex_to<GiNaC::numeric>(parsed);
}

/** The canonical spec of the discretization `name` (with its parameter `value` when `has_value`). */
DiscretizationSpec Reader::discretization_spec(const Line& line, const Token& name, bool has_value,
                                               const GiNaC::numeric& value, int value_col,
                                               const std::string& available) const {
DiscretizationSpec spec;
if (name.text == "galerkin_gauss" || name.text == "galerkin_lobatto") {
  if (!has_value) fail(line, name, name.text + " needs its parameter s, e.g. " + name.text + "(s=4) (consistency order 2 s)");
  spec = galerkin_spec(name.text == "galerkin_gauss" ? DiscretizationKind::galerkin_gauss
                                                     : DiscretizationKind::galerkin_lobatto,
                       model_.order, value.to_int());
} else if (name.text == "hermite_gauss") {
  spec.kind = DiscretizationKind::hermite_gauss;
  spec.stages = has_value ? value.to_int() : model_.order;
  if (spec.stages < model_.order) {
    fail(line.number, value_col,
         "hermite_gauss(s=" + std::to_string(spec.stages) + ") is not regular for an order-" +
             std::to_string(model_.order) + " model: the interpolant's derivative of order " +
             std::to_string(model_.order) + " is a polynomial of degree " + std::to_string(model_.order - 1) +
             " that can vanish at all " + std::to_string(spec.stages) + " Gauss points (s must be at least " +
             std::to_string(model_.order) + ")");
  }
  spec = hermite_gauss_spec(model_.order, spec.stages);
} else if (model_.order == 1 && (name.text == "trapezoid" || name.text == "midpoint")) {
  if (has_value) {
    fail(line.number, value_col, "'trapezoid' takes no parameters for order-1 models (alpha is for order 2)");
  }
  spec.kind = name.text == "trapezoid" ? DiscretizationKind::trapezoid : DiscretizationKind::midpoint;
  spec.name = spec.ident = name.text;
  spec.consistency_order = 2;
} else if (model_.order == 2 && name.text == "trapezoid") {
  spec.kind = DiscretizationKind::trapezoid_alpha;
  spec.alpha = value;
  spec.name = "trapezoid(alpha=" + rational_text(value) + ")";
  spec.ident = "trapezoid_alpha_" + rational_ident(value);
  spec.consistency_order = 2;
} else if (model_.order == 2 && name.text == "gauss2") {
  spec.kind = DiscretizationKind::gauss2;
  spec.name = spec.ident = "gauss2";
  spec.consistency_order = 4;
} else if (name.text == "trapezoid" || name.text == "midpoint" || name.text == "gauss2") {
  fail(line, name, "'" + name.text + "' is not available for order-" + std::to_string(model_.order) +
                       " models (available: " + available + ")");
} else {
  fail(line, name, "unknown discretization '" + name.text + "' (available for order-" +
                       std::to_string(model_.order) + " models: " + available + ")");
}
  return spec;
}

}  // namespace pardel_codegen::lag

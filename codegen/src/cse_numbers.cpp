/**
 * @file cse_numbers.cpp
 * The constants of the CSE: GiNaC constants rounded once to double and to extended precision,
 * their C literals (c_double_literal, c_extended_literal), the check for numbers beyond 1e300
 * (has_huge_number, which the .lag reader shares), and the table of emittable functions.
 */
#include <cmath>
#include <cstdio>
#include <map>

#include "cse_numbers.hpp"

namespace pardel_codegen {

std::string c_double_literal(double value) {
  if (!std::isfinite(value)) throw CodegenError("a constant of the model is not finite");
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", value);
  std::string s(buf);
  if (s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}

std::string c_extended_literal(ExtendedFloat value) {
  double parts[3] = {0, 0, 0};
  ExtendedFloat rest = value;
  int n = 0;
  for (; n < 3; ++n) {
    parts[n] = static_cast<double>(rest);
    if (parts[n] == 0) break;
    rest -= parts[n];
  }
  if (n <= 1) return c_double_literal(parts[0]);
  std::string s = "(pd_quad(" + c_double_literal(parts[0]) + ")";
  for (int i = 1; i < n; ++i) s += (parts[i] < 0 ? " - " : " + ") + c_double_literal(std::fabs(parts[i]));
  return s + ")";
}

bool has_huge_number(const GiNaC::ex& e) {
  if (GiNaC::is_a<GiNaC::numeric>(e)) return GiNaC::abs(GiNaC::ex_to<GiNaC::numeric>(e)) > GiNaC::numeric(1e300);
  for (std::size_t i = 0; i < e.nops(); ++i) {
    if (has_huge_number(e.op(i))) return true;
  }
  return false;
}

namespace cse {
namespace {

double checked(double v, const char* what) {
  if (!std::isfinite(v)) throw CodegenError(std::string("a constant subexpression (") + what + ") is not finite");
  return v;
}

/** A double as an exact rational. */
GiNaC::numeric exact_double(double d) {
  int e = 0;
  const double m = std::frexp(d, &e);
  return GiNaC::numeric(static_cast<long>(std::ldexp(m, 53))) * GiNaC::numeric(2).power(e - 53);
}

}  // namespace

std::string hex(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

const FunctionInfo* function_info(const std::string& name) {
  static const std::map<std::string, FunctionInfo> table = {
      {"sin", {"std::sin", "sinq", 1, 1, [](double x) { return std::sin(x); }, nullptr}},
      {"cos", {"std::cos", "cosq", 1, 2, [](double x) { return std::cos(x); }, nullptr}},
      {"tan", {"std::tan", "tanq", 1, 1, [](double x) { return std::tan(x); }, nullptr}},
      {"exp", {"std::exp", "expq", 1, 0, [](double x) { return std::exp(x); }, nullptr}},
      {"log", {"std::log", "logq", 1, 0, [](double x) { return std::log(x); }, nullptr}},
      {"sqrt", {"std::sqrt", "sqrtq", 1, 0, [](double x) { return std::sqrt(x); }, nullptr}},
      {"sinh", {"std::sinh", "sinhq", 1, 1, [](double x) { return std::sinh(x); }, nullptr}},
      {"cosh", {"std::cosh", "coshq", 1, 2, [](double x) { return std::cosh(x); }, nullptr}},
      {"tanh", {"std::tanh", "tanhq", 1, 1, [](double x) { return std::tanh(x); }, nullptr}},
      {"asin", {"std::asin", "asinq", 1, 1, [](double x) { return std::asin(x); }, nullptr}},
      {"acos", {"std::acos", "acosq", 1, 0, [](double x) { return std::acos(x); }, nullptr}},
      {"atan", {"std::atan", "atanq", 1, 1, [](double x) { return std::atan(x); }, nullptr}},
      {"atan2", {"std::atan2", "atan2q", 2, 0, nullptr, [](double y, double x) { return std::atan2(y, x); }}},
      {"pow", {"std::pow", "powq", 2, 0, nullptr, [](double x, double y) { return std::pow(x, y); }}},
  };
  auto it = table.find(name);
  return it == table.end() ? nullptr : &it->second;
}

double value_of(const GiNaC::ex& c) {
  if (GiNaC::is_a<GiNaC::numeric>(c) && GiNaC::ex_to<GiNaC::numeric>(c).is_rational()) {
    return checked(GiNaC::ex_to<GiNaC::numeric>(c).to_double(), "a number");
  }
  if (has_huge_number(c)) throw CodegenError("a constant of the model is beyond 1e300 in magnitude");
  GiNaC::ex v = c.evalf();
  if (!GiNaC::is_a<GiNaC::numeric>(v)) throw CodegenError("internal: a constant has no numeric value");
  const GiNaC::numeric& n = GiNaC::ex_to<GiNaC::numeric>(v);
  if (!n.is_real()) throw CodegenError("the model has a complex constant");
  // cln converts values beyond the range of double without notice; check the range first.
  if (GiNaC::abs(n) > GiNaC::numeric(1.7976931348623157e308)) {
    throw CodegenError("a constant subexpression (a constant) is not finite");
  }
  return checked(n.to_double(), "a constant");
}

Num num_of(const GiNaC::ex& c) {
  const double d = value_of(c);
  GiNaC::numeric rest;
  if (GiNaC::is_a<GiNaC::numeric>(c) && GiNaC::ex_to<GiNaC::numeric>(c).is_rational()) {
    rest = GiNaC::ex_to<GiNaC::numeric>(c);
  } else {
    const long saved = GiNaC::Digits;
    GiNaC::Digits = 60;
    rest = GiNaC::ex_to<GiNaC::numeric>(c.evalf());
    GiNaC::Digits = saved;
  }
  ExtendedFloat q = 0;
  for (int i = 0; i < 3; ++i) {
    const double part = rest.to_double();
    if (part == 0 || !std::isfinite(part)) break;
    q += part;
    rest = rest - exact_double(part);
  }
  return {d, q};
}

}  // namespace cse
}  // namespace pardel_codegen

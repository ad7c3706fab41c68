/**
 * @file cse_convert.cpp
 * The conversion of GiNaC expressions into the CSE's n-ary DAG: constants stay exact (as
 * coefficients) while converting, integer and half-integer powers become product factors and
 * square roots, and every function must be one the generator can emit.
 */
#include <sstream>

#include "cse_nary.hpp"

namespace pardel_codegen::cse {

Exact Converter::convert(const GiNaC::ex& e) {
  using namespace GiNaC;
  if (is_a<numeric>(e)) {
    if (!ex_to<numeric>(e).is_real()) throw CodegenError("the model has a complex constant (" + to_string(e) + ")");
    return {e, -1};
  }
  if (is_a<symbol>(e)) {
    auto it = inputs_.find(e);
    if (it == inputs_.end()) throw CodegenError("internal: the expression reads an unknown symbol " + to_string(e));
    NNode n;
    n.kind = NKind::input;
    n.name = it->second->c_name;
    n.group = it->second->group;
    return {1, dag_.intern(std::move(n))};
  }
  if (is_a<constant>(e)) {
    value_of(e);
    return {e, -1};
  }
  auto memo = memo_.find(e);
  if (memo != memo_.end()) return memo->second;
  Exact result = convert_composite(e);
  memo_.emplace(e, result);
  return result;
}

int Converter::materialize(const Exact& x) {
  if (x.node < 0) return dag_.constant(num_of(x.coef));
  return dag_.materialize({num_of(x.coef), x.node});
}

std::string Converter::to_string(const GiNaC::ex& e) {
  std::ostringstream s;
  s << e;
  return s.str();
}

bool Converter::small_integer(const GiNaC::ex& e, int* out) {
  if (!GiNaC::is_a<GiNaC::numeric>(e)) return false;
  const GiNaC::numeric& n = GiNaC::ex_to<GiNaC::numeric>(e);
  if (!n.is_integer() || GiNaC::abs(n) > 1000000) return false;
  *out = n.to_int();
  return true;
}

Exact Converter::power_of(const Exact& base, int k) {
  const GiNaC::ex coef = GiNaC::pow(base.coef, k);
  value_of(coef);  // finite
  if (base.node < 0) return {coef, -1};
  std::map<int, int> f;
  dag_.add_factor(f, base.node, k);
  return dag_.make_product(coef, f);
}

Exact Converter::convert_composite(const GiNaC::ex& e) {
  using namespace GiNaC;
  if (is_a<add>(e)) return convert_sum(e);
  if (is_a<mul>(e)) return convert_product(e);
  if (is_a<power>(e)) return convert_power(e);
  if (is_a<function>(e)) return convert_call(e);
  throw CodegenError("cannot emit the expression " + to_string(e));
}

/** A GiNaC add: its terms gathered by node, the constant terms summed exactly. */
Exact Converter::convert_sum(const GiNaC::ex& e) {
  using namespace GiNaC;
  std::vector<std::pair<ex, int>> terms;
  ex constant_term = 0;
  for (std::size_t i = 0; i < e.nops(); ++i) {
    Exact x = convert(e.op(i));
    if (x.node < 0) constant_term += x.coef;
    else terms.emplace_back(x.coef, x.node);
  }
  return dag_.make_sum(terms, constant_term);
}

/** A GiNaC mul: small integer powers of its factors become exponents, the coefficients multiply exactly. */
Exact Converter::convert_product(const GiNaC::ex& e) {
  using namespace GiNaC;
  ex coef = 1;
  std::map<int, int> factors;
  for (std::size_t i = 0; i < e.nops(); ++i) {
    const ex& f = e.op(i);
    int k = 0;
    Exact x{1, -1};
    if (is_a<power>(f) && small_integer(f.op(1), &k)) {
      x = power_of(convert(f.op(0)), k);
    } else {
      x = convert(f);
    }
    coef *= x.coef;
    if (x.node >= 0) dag_.add_factor(factors, x.node, 1);
  }
  value_of(coef);
  return dag_.make_product(coef, factors);
}

/** A GiNaC power: integer exponents as factors, half-integer ones through sqrt, others as a call of pow. */
Exact Converter::convert_power(const GiNaC::ex& e) {
  using namespace GiNaC;
  const ex& base = e.op(0);
  const ex& exponent = e.op(1);
  int k = 0;
  if (small_integer(exponent, &k)) return power_of(convert(base), k);
  if (is_a<numeric>(exponent) && ex_to<numeric>(exponent).is_rational() &&
      ex_to<numeric>(exponent).denom() == 2 && abs(ex_to<numeric>(exponent).numer()) < 1000000) {
    int num = ex_to<numeric>(exponent).numer().to_int();
    Exact b = convert(base);
    if (b.node < 0) {
      if (value_of(b.coef) < 0) throw CodegenError("the model takes the square root of a negative constant");
      value_of(e);
      return {e, -1};
    }
    NNode sq;
    sq.kind = NKind::call;
    sq.name = "sqrt";
    sq.args = {materialize(b)};
    return power_of({1, dag_.intern(std::move(sq))}, num);
  }
  Exact b = convert(base);
  Exact x = convert(exponent);
  if (b.node < 0 && x.node < 0) {
    value_of(e);
    return {e, -1};
  }
  NNode n;
  n.kind = NKind::call;
  n.name = "pow";
  n.args = {materialize(b), materialize(x)};
  return {1, dag_.intern(std::move(n))};
}

/** A GiNaC function call: the function must be one the generator can emit. */
Exact Converter::convert_call(const GiNaC::ex& e) {
  using namespace GiNaC;
  const std::string name = ex_to<function>(e).get_name();
  const FunctionInfo* info = function_info(name);
  if (info == nullptr || static_cast<int>(e.nops()) != info->arity) {
    throw CodegenError("the derivatives use the function '" + name + "', which cannot be emitted");
  }
  std::vector<Exact> args;
  bool all_constant = true;
  for (std::size_t i = 0; i < e.nops(); ++i) {
    args.push_back(convert(e.op(i)));
    all_constant = all_constant && args.back().node < 0;
  }
  if (all_constant) {
    value_of(e);
    return {e, -1};
  }
  NNode n;
  n.kind = NKind::call;
  n.name = name;
  for (const Exact& a : args) n.args.push_back(materialize(a));
  return {1, dag_.intern(std::move(n))};
}

}  // namespace pardel_codegen::cse

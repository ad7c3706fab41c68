/**
 * @file cse.cpp
 * Common-subexpression elimination for generated kernels (see cse.hpp for the design):
 * GiNaC expressions -> hash-consed n-ary DAG -> greedy factoring of shared sub-sums and
 * sub-products -> binary DAG (hash-consed again) -> straight-line C with temporaries.
 */
#include "pardel_codegen/cse.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <numeric>
#include <optional>
#include <unordered_map>

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

namespace {

std::string hex(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

// ---------------------------------------------------------------------------------------------
// Constants: a double, which every decision of the CSE reads (so that the double kernels do not
// depend on the extended-precision printing), with the same value in extended precision beside it,
// carried through the same arithmetic, for the extended-precision kernels.

struct Num {
  double d = 0;
  ExtendedFloat q = 0;
  Num() = default;
  Num(double v) : d(v), q(v) {}  // NOLINT: exact (integers, 1.0, a double's own value)
  Num(double dv, ExtendedFloat qv) : d(dv), q(qv) {}
};
Num operator+(const Num& a, const Num& b) { return {a.d + b.d, a.q + b.q}; }
Num operator/(const Num& a, const Num& b) { return {a.d / b.d, a.q / b.q}; }
Num operator-(const Num& a) { return {-a.d, -a.q}; }
Num& operator+=(Num& a, const Num& b) { return a = a + b; }
Num abs_of(const Num& a) { return a.d < 0 ? -a : a; }

// ---------------------------------------------------------------------------------------------
// Functions the generator can emit.

struct FunctionInfo {
  const char* c_name;
  const char* quad_name;  ///< the libquadmath function of the extended-precision kernels
  int arity;
  int parity;  ///< 1: odd, f(-x) = -f(x); 2: even, f(-x) = f(x); 0: neither
  double (*fold1)(double);
  double (*fold2)(double, double);
};

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

double checked(double v, const char* what) {
  if (!std::isfinite(v)) throw CodegenError(std::string("a constant subexpression (") + what + ") is not finite");
  return v;
}

// ---------------------------------------------------------------------------------------------
// The n-ary DAG.

enum class NKind { constant, input, sum, product, call };

struct NTerm {
  Num coef;
  int node;
};
struct NFactor {
  int node;
  int exp;
};

struct NNode {
  NKind kind = NKind::constant;
  Num value = 0;               ///< constant
  std::string name;            ///< input: C name; call: function name
  std::string group;           ///< input: kernel argument
  std::vector<NTerm> terms;    ///< sum: sorted by node id
  Num constant = 0;            ///< sum: constant term
  std::vector<NFactor> factors;///< product: sorted by node id
  std::vector<int> args;       ///< call
  /** A structural hash independent of node ids and of GiNaC's (address-seeded) term order;
   *  it orders terms and factors so that the output does not depend on either. */
  std::uint64_t shash = 0;
};

/** value = coef * node, or just coef when node < 0. */
struct Scaled {
  Num coef;
  int node;
};

/** The same with an exact constant coefficient (rationals, sqrt(3), pi, ...), kept exact while
 *  converting so that the doubles finally printed do not depend on how GiNaC happened to
 *  write an equal constant (2/3 sqrt(3) or 2 3^(-1/2)). */
struct Exact {
  GiNaC::ex coef;
  int node;
};

/** True when a number in `c` is beyond 1e300 in magnitude: GiNaC's evalf of functions of such
 *  numbers is not reliable (exp(10^308) evaluates to 1.0), and no double kernel needs them. */
bool has_huge_number(const GiNaC::ex& c) {
  if (GiNaC::is_a<GiNaC::numeric>(c)) return GiNaC::abs(GiNaC::ex_to<GiNaC::numeric>(c)) > GiNaC::numeric(1e300);
  for (std::size_t i = 0; i < c.nops(); ++i) {
    if (has_huge_number(c.op(i))) return true;
  }
  return false;
}

/** A constant expression rounded once to double (GiNaC::Digits is raised while generating). */
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

/** A double as an exact rational. */
GiNaC::numeric exact_double(double d) {
  int e = 0;
  const double m = std::frexp(d, &e);
  return GiNaC::numeric(static_cast<long>(std::ldexp(m, 53))) * GiNaC::numeric(2).power(e - 53);
}

/** A constant expression rounded once to double, and to extended precision (the sum of up to three
 *  doubles taken from an evaluation at 60 digits: a correctly rounded __float128 up to its last
 *  bit). */
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

std::uint64_t mix(std::uint64_t h, std::uint64_t v) {
  h ^= v + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
  h ^= h >> 31;
  h *= 0xbf58476d1ce4e5b9ULL;
  return h ^ (h >> 29);
}
std::uint64_t bits(double v) {
  std::uint64_t b = 0;
  if (v == 0) v = 0;  // -0.0 and 0.0 alike
  std::memcpy(&b, &v, sizeof b);
  return b;
}
std::uint64_t text_hash(const std::string& s) {
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ULL;
  return h;
}

class NDag {
 public:
  std::vector<NNode> nodes;

  std::uint64_t shash(int id) const { return nodes[static_cast<std::size_t>(id)].shash; }

  /** Sorts terms and factors by the structural hash of their nodes (then coefficient). */
  void canonicalize(NNode& n) const {
    std::sort(n.terms.begin(), n.terms.end(), [&](const NTerm& x, const NTerm& y) {
      if (shash(x.node) != shash(y.node)) return shash(x.node) < shash(y.node);
      return x.coef.d < y.coef.d;
    });
    std::sort(n.factors.begin(), n.factors.end(), [&](const NFactor& x, const NFactor& y) {
      if (shash(x.node) != shash(y.node)) return shash(x.node) < shash(y.node);
      return x.exp < y.exp;
    });
  }

  std::uint64_t structural_hash(const NNode& n) const {
    std::uint64_t h = mix(0x5bd1e995u, static_cast<std::uint64_t>(n.kind));
    switch (n.kind) {
      case NKind::constant: return mix(h, bits(n.value.d));
      case NKind::input: return mix(h, text_hash(n.name));
      case NKind::sum:
        h = mix(h, bits(n.constant.d));
        for (const NTerm& t : n.terms) h = mix(mix(h, shash(t.node)), bits(t.coef.d));
        return h;
      case NKind::product:
        for (const NFactor& f : n.factors) h = mix(mix(h, shash(f.node)), static_cast<std::uint64_t>(f.exp));
        return h;
      case NKind::call:
        h = mix(h, text_hash(n.name));
        for (int a : n.args) h = mix(h, shash(a));
        return h;
    }
    return h;
  }

  static std::string key_of(const NNode& n) {
    std::string k;
    switch (n.kind) {
      case NKind::constant: k = "c" + hex(n.value.d); break;
      case NKind::input: k = "i" + n.name; break;
      case NKind::sum:
        k = "s" + hex(n.constant.d);
        for (const NTerm& t : n.terms) k += "|" + std::to_string(t.node) + "*" + hex(t.coef.d);
        break;
      case NKind::product:
        k = "p";
        for (const NFactor& f : n.factors) k += "|" + std::to_string(f.node) + "^" + std::to_string(f.exp);
        break;
      case NKind::call:
        k = "f" + n.name;
        for (int a : n.args) k += "|" + std::to_string(a);
        break;
    }
    return k;
  }

  int intern(NNode n) {
    canonicalize(n);
    std::string k = key_of(n);
    auto it = table_.find(k);
    if (it != table_.end()) return it->second;
    n.shash = structural_hash(n);
    int id = static_cast<int>(nodes.size());
    nodes.push_back(std::move(n));
    table_.emplace(std::move(k), id);
    return id;
  }

  /** Replaces the contents of node `id` (the factoring passes rewrite sums and products in place). */
  void rewrite(int id, NNode replacement) {
    canonicalize(replacement);
    replacement.shash = nodes[static_cast<std::size_t>(id)].shash;
    std::string old_key = key_of(nodes[static_cast<std::size_t>(id)]);
    auto it = table_.find(old_key);
    if (it != table_.end() && it->second == id) table_.erase(it);
    nodes[static_cast<std::size_t>(id)] = std::move(replacement);
    table_.emplace(key_of(nodes[static_cast<std::size_t>(id)]), id);
  }

  int constant(Num v) {
    NNode n;
    n.kind = NKind::constant;
    n.value = v;
    return intern(std::move(n));
  }

  int materialize(Scaled s) {
    if (s.node < 0) return constant(s.coef);
    if (s.coef.d == 1) return s.node;
    NNode n;
    n.kind = NKind::sum;
    n.terms.push_back(NTerm{s.coef, s.node});
    return intern(std::move(n));
  }

  /**
   * A sum of exact coefficient * node terms plus an exact constant. A common sign, or a common
   * magnitude of all coefficients, is pulled out and returned as the scale.
   */
  Exact make_sum(const std::vector<std::pair<GiNaC::ex, int>>& raw, const GiNaC::ex& constant_term) {
    std::map<int, GiNaC::ex> acc;
    for (const auto& [coef, node] : raw) acc[node] += coef;
    std::vector<std::pair<GiNaC::ex, int>> terms;
    for (const auto& [node, coef] : acc) {
      if (value_of(coef) != 0) terms.emplace_back(coef, node);
    }
    std::sort(terms.begin(), terms.end(), [&](const auto& x, const auto& y) {
      if (shash(x.second) != shash(y.second)) return shash(x.second) < shash(y.second);
      return value_of(x.first) < value_of(y.first);
    });
    const double c = value_of(constant_term);
    if (terms.empty()) return {constant_term, -1};
    if (terms.size() == 1 && c == 0) return {terms[0].first, terms[0].second};
    const double first = value_of(terms[0].first);
    GiNaC::ex scale = first < 0 ? -1 : 1;
    bool equal = c == 0 || std::fabs(c) == std::fabs(first);
    for (const auto& t : terms) equal = equal && std::fabs(value_of(t.first)) == std::fabs(first);
    if (equal) scale = terms[0].first;
    NNode n;
    n.kind = NKind::sum;
    for (const auto& [coef, node] : terms) n.terms.push_back(NTerm{num_of(coef / scale), node});
    n.constant = num_of(constant_term / scale);
    return {scale, intern(std::move(n))};
  }

  Exact make_product(const GiNaC::ex& coef, const std::map<int, int>& raw) {
    std::vector<NFactor> factors;
    for (const auto& [node, e] : raw) {
      if (e != 0) factors.push_back({node, e});
    }
    if (factors.empty()) return {coef, -1};
    if (factors.size() == 1 && factors[0].exp == 1) return {coef, factors[0].node};
    NNode n;
    n.kind = NKind::product;
    n.factors = std::move(factors);
    return {coef, intern(std::move(n))};
  }

  /** Adds node^e to a product's factors, flattening nested products. */
  void add_factor(std::map<int, int>& factors, int node, int e) {
    const NNode& n = nodes[static_cast<std::size_t>(node)];
    if (n.kind == NKind::product) {
      std::vector<NFactor> inner = n.factors;
      for (const NFactor& f : inner) factors[f.node] += f.exp * e;
    } else {
      factors[node] += e;
    }
  }

 private:
  std::unordered_map<std::string, int> table_;
};

// ---------------------------------------------------------------------------------------------
// GiNaC -> n-ary DAG.

class Converter {
 public:
  Converter(NDag& dag, const std::vector<KernelInput>& inputs) : dag_(dag) {
    for (const KernelInput& in : inputs) inputs_.emplace(in.symbol, &in);
  }

  Exact convert(const GiNaC::ex& e) {
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

  /** The node of a converted value (a constant node, the node itself, or a scaled node). */
  int materialize(const Exact& x) {
    if (x.node < 0) return dag_.constant(num_of(x.coef));
    return dag_.materialize({num_of(x.coef), x.node});
  }

 private:
  static std::string to_string(const GiNaC::ex& e) {
    std::ostringstream s;
    s << e;
    return s.str();
  }

  static bool small_integer(const GiNaC::ex& e, int* out) {
    if (!GiNaC::is_a<GiNaC::numeric>(e)) return false;
    const GiNaC::numeric& n = GiNaC::ex_to<GiNaC::numeric>(e);
    if (!n.is_integer() || GiNaC::abs(n) > 1000000) return false;
    *out = n.to_int();
    return true;
  }

  Exact power_of(const Exact& base, int k) {
    const GiNaC::ex coef = GiNaC::pow(base.coef, k);
    value_of(coef);  // finite
    if (base.node < 0) return {coef, -1};
    std::map<int, int> f;
    dag_.add_factor(f, base.node, k);
    return dag_.make_product(coef, f);
  }

  Exact convert_composite(const GiNaC::ex& e) {
    using namespace GiNaC;
    if (is_a<add>(e)) {
      std::vector<std::pair<ex, int>> terms;
      ex constant_term = 0;
      for (std::size_t i = 0; i < e.nops(); ++i) {
        Exact x = convert(e.op(i));
        if (x.node < 0) constant_term += x.coef;
        else terms.emplace_back(x.coef, x.node);
      }
      return dag_.make_sum(terms, constant_term);
    }
    if (is_a<mul>(e)) {
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
    if (is_a<power>(e)) {
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
    if (is_a<function>(e)) {
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
    throw CodegenError("cannot emit the expression " + to_string(e));
  }

  NDag& dag_;
  std::map<GiNaC::ex, const KernelInput*, GiNaC::ex_is_less> inputs_;
  /** Keyed by value (the map holds the expressions, so keys stay valid). */
  std::map<GiNaC::ex, Exact, GiNaC::ex_is_less> memo_;
};

// ---------------------------------------------------------------------------------------------
// Factoring of shared sub-sums and sub-products.

std::vector<char> reachable(const NDag& dag, const std::vector<Scaled>& roots) {
  std::vector<char> seen(dag.nodes.size(), 0);
  std::vector<int> stack;
  for (const Scaled& r : roots) {
    if (r.node >= 0) stack.push_back(r.node);
  }
  while (!stack.empty()) {
    int id = stack.back();
    stack.pop_back();
    if (seen[static_cast<std::size_t>(id)]) continue;
    seen[static_cast<std::size_t>(id)] = 1;
    const NNode& n = dag.nodes[static_cast<std::size_t>(id)];
    for (const NTerm& t : n.terms) stack.push_back(t.node);
    for (const NFactor& f : n.factors) stack.push_back(f.node);
    for (int a : n.args) stack.push_back(a);
  }
  return seen;
}

struct PairKey {
  int a, b;
  double r;  ///< sums: coef_b / coef_a
  int ea, eb;///< products: normalized exponents
  bool operator==(const PairKey& o) const { return a == o.a && b == o.b && r == o.r && ea == o.ea && eb == o.eb; }
  bool operator<(const PairKey& o) const {
    if (a != o.a) return a < o.a;
    if (b != o.b) return b < o.b;
    if (r != o.r) return r < o.r;
    if (ea != o.ea) return ea < o.ea;
    return eb < o.eb;
  }
};
struct PairKeyHash {
  std::size_t operator()(const PairKey& k) const {
    std::size_t h = std::hash<int>()(k.a) * 1000003u ^ std::hash<int>()(k.b);
    h = h * 1000003u ^ std::hash<double>()(k.r);
    h = h * 1000003u ^ static_cast<std::size_t>(k.ea * 31 + k.eb);
    return h;
  }
};

constexpr std::size_t kMaxTermsForPairs = 64;

PairKey product_key(const NFactor& x, const NFactor& y) {
  int g = std::gcd(std::abs(x.exp), std::abs(y.exp));
  int s = x.exp > 0 ? 1 : -1;
  return PairKey{x.node, y.node, 0.0, x.exp / g * s, y.exp / g * s};
}

/**
 * Copies the part of `dag` reachable from `roots` into a fresh DAG, interning every node by its
 * content: duplicates left by in-place rewrites merge, identity sums and products collapse, and
 * node ids and structural hashes become functions of the content alone (so of nothing that
 * varies between runs).
 */
void rebuild(NDag& dag, std::vector<Scaled>& roots) {
  NDag fresh;
  std::vector<int> map(dag.nodes.size(), -1);
  std::function<int(int)> copy = [&](int id) -> int {
    int& m = map[static_cast<std::size_t>(id)];
    if (m >= 0) return m;
    NNode n = dag.nodes[static_cast<std::size_t>(id)];
    // Children that were duplicates merge here, so terms and factors are gathered again.
    std::map<int, Num> terms;
    for (const NTerm& t : n.terms) terms[copy(t.node)] += t.coef;
    std::map<int, int> factors;
    for (const NFactor& f : n.factors) factors[copy(f.node)] += f.exp;
    n.terms.clear();
    for (const auto& [node, coef] : terms) {
      if (coef.d != 0) n.terms.push_back({coef, node});
    }
    n.factors.clear();
    for (const auto& [node, e] : factors) {
      if (e != 0) n.factors.push_back({node, e});
    }
    for (int& a : n.args) a = copy(a);
    n.shash = 0;
    if (n.kind == NKind::sum && n.terms.empty()) {
      m = fresh.constant(n.constant);
    } else if (n.kind == NKind::product && n.factors.empty()) {
      m = fresh.constant(1.0);
    } else if (n.kind == NKind::sum && n.terms.size() == 1 && n.terms[0].coef.d == 1 && n.constant.d == 0) {
      m = n.terms[0].node;
    } else if (n.kind == NKind::product && n.factors.size() == 1 && n.factors[0].exp == 1) {
      m = n.factors[0].node;
    } else {
      m = fresh.intern(std::move(n));
    }
    return m;
  };
  for (Scaled& r : roots) {
    if (r.node >= 0) r.node = copy(r.node);
  }
  dag = std::move(fresh);
}

/** Factors sub-sums (products when `products`) shared by two or more nodes; returns rounds used. */
int factor_pairs(NDag& dag, std::vector<Scaled>& roots, bool products, int max_rounds) {
  const NKind kind = products ? NKind::product : NKind::sum;
  int rounds = 0;
  for (; rounds < max_rounds; ++rounds) {
    rebuild(dag, roots);
    std::vector<char> live = reachable(dag, roots);
    std::unordered_map<PairKey, std::vector<int>, PairKeyHash> holders;
    for (std::size_t id = 0; id < dag.nodes.size(); ++id) {
      const NNode& n = dag.nodes[id];
      if (!live[id] || n.kind != kind) continue;
      if (!products) {
        if (n.terms.size() < 2 || n.terms.size() > kMaxTermsForPairs) continue;
        for (std::size_t i = 0; i < n.terms.size(); ++i) {
          for (std::size_t j = i + 1; j < n.terms.size(); ++j) {
            if (n.terms[i].node == n.terms[j].node) continue;
            PairKey k{n.terms[i].node, n.terms[j].node, n.terms[j].coef.d / n.terms[i].coef.d, 0, 0};
            holders[k].push_back(static_cast<int>(id));
          }
        }
      } else {
        if (n.factors.size() < 2 || n.factors.size() > kMaxTermsForPairs) continue;
        for (std::size_t i = 0; i < n.factors.size(); ++i) {
          for (std::size_t j = i + 1; j < n.factors.size(); ++j) {
            if (n.factors[i].node == n.factors[j].node) continue;
            holders[product_key(n.factors[i], n.factors[j])].push_back(static_cast<int>(id));
          }
        }
      }
    }
    std::vector<std::pair<PairKey, const std::vector<int>*>> candidates;
    for (const auto& [key, ids] : holders) {
      if (ids.size() >= 2) candidates.emplace_back(key, &ids);
    }
    if (candidates.empty()) break;
    std::sort(candidates.begin(), candidates.end(), [&](const auto& x, const auto& y) {
      if (x.second->size() != y.second->size()) return x.second->size() > y.second->size();
      const PairKey& a = x.first;
      const PairKey& b = y.first;
      if (dag.shash(a.a) != dag.shash(b.a)) return dag.shash(a.a) < dag.shash(b.a);
      if (dag.shash(a.b) != dag.shash(b.b)) return dag.shash(a.b) < dag.shash(b.b);
      if (a.r != b.r) return a.r < b.r;
      if (a.ea != b.ea) return a.ea < b.ea;
      return a.eb < b.eb;
    });
    bool changed = false;
    for (const auto& [key, ids] : candidates) {
      // The nodes that still hold the pair after this round's earlier rewrites.
      std::vector<std::pair<int, int>> hits;  // node id, position of key.a
      Num ratio = key.r;  // the ratio with its extended-precision value, from the first holder
      for (int id : *ids) {
        const NNode& n = dag.nodes[static_cast<std::size_t>(id)];
        if (!products) {
          const NTerm* ta = nullptr;
          const NTerm* tb = nullptr;
          for (const NTerm& t : n.terms) {
            if (t.node == key.a) ta = &t;
            if (t.node == key.b) tb = &t;
          }
          if (ta && tb && tb->coef.d / ta->coef.d == key.r) {
            if (hits.empty()) ratio = tb->coef / ta->coef;
            hits.emplace_back(id, 0);
          }
        } else {
          const NFactor* fa = nullptr;
          const NFactor* fb = nullptr;
          for (const NFactor& f : n.factors) {
            if (f.node == key.a) fa = &f;
            if (f.node == key.b) fb = &f;
          }
          if (fa && fb && product_key(*fa, *fb) == key) hits.emplace_back(id, 0);
        }
      }
      if (hits.size() < 2) continue;
      NNode shared;
      shared.kind = kind;
      if (!products) {
        shared.terms.push_back(NTerm{1.0, key.a});
        shared.terms.push_back(NTerm{ratio, key.b});
      } else {
        shared.factors.push_back(NFactor{key.a, key.ea});
        shared.factors.push_back(NFactor{key.b, key.eb});
      }
      const int s = dag.intern(shared);
      for (const auto& hit : hits) {
        const int id = hit.first;
        if (id == s) continue;
        NNode n = dag.nodes[static_cast<std::size_t>(id)];
        if (!products) {
          Num ca = 0;
          std::map<int, Num> acc;
          for (const NTerm& t : n.terms) {
            if (t.node == key.a) ca = t.coef;
            else if (t.node != key.b) acc[t.node] += t.coef;
          }
          acc[s] += ca;
          n.terms.clear();
          for (const auto& [node, coef] : acc) {
            if (coef.d != 0) n.terms.push_back({coef, node});
          }
        } else {
          int k = 0;
          std::map<int, int> acc;
          for (const NFactor& f : n.factors) {
            if (f.node == key.a) k = f.exp / key.ea;
            else if (f.node != key.b) acc[f.node] += f.exp;
          }
          acc[s] += k;
          n.factors.clear();
          for (const auto& [node, e] : acc) {
            if (e != 0) n.factors.push_back({node, e});
          }
        }
        dag.rewrite(id, std::move(n));
        changed = true;
      }
    }
    if (!changed) break;
  }
  return rounds;
}

// ---------------------------------------------------------------------------------------------
// The binary DAG and its printing.

enum class BOp { constant, input, add, sub, mul, div, neg, call };

struct BNode {
  BOp op = BOp::constant;
  Num value = 0;
  std::string name;  ///< input: C name; call: C function name
  std::string group; ///< input: kernel argument
  std::vector<int> kids;
};

class BDag {
 public:
  std::vector<BNode> nodes;

  int intern(BNode n) {
    if ((n.op == BOp::add || n.op == BOp::mul) && n.kids[0] > n.kids[1]) std::swap(n.kids[0], n.kids[1]);
    std::string k = std::to_string(static_cast<int>(n.op)) + ":" + hex(n.value.d) + ":" + n.name;
    for (int c : n.kids) k += "," + std::to_string(c);
    auto it = table_.find(k);
    if (it != table_.end()) return it->second;
    int id = static_cast<int>(nodes.size());
    nodes.push_back(std::move(n));
    table_.emplace(std::move(k), id);
    return id;
  }
  int op(BOp o, std::vector<int> kids) {
    BNode n;
    n.op = o;
    n.kids = std::move(kids);
    return intern(std::move(n));
  }
  int constant(Num v) {
    BNode n;
    n.op = BOp::constant;
    n.value = v;
    return intern(std::move(n));
  }
  bool leaf(int id) const {
    BOp o = nodes[static_cast<std::size_t>(id)].op;
    return o == BOp::constant || o == BOp::input;
  }

 private:
  std::unordered_map<std::string, int> table_;
};

struct Signed {
  int sign;
  int node;
};

class Lowerer {
 public:
  Lowerer(const NDag& n, BDag& b) : n_(n), b_(b), memo_(n.nodes.size()) {}

  /** The binary node of an output value coef * node (node < 0: a constant). */
  int lower_output(const Scaled& s) {
    if (s.node < 0) return b_.constant(s.coef);
    const Num magnitude = abs_of(s.coef);
    Signed l = magnitude.d == 1 ? lower(s.node) : lower_scaled(magnitude, s.node);
    const int sign = (s.coef.d < 0 ? -1 : 1) * l.sign;
    return sign > 0 ? l.node : b_.op(BOp::neg, {l.node});
  }

 private:
  Signed lower(int id) {
    if (memo_[static_cast<std::size_t>(id)]) return *memo_[static_cast<std::size_t>(id)];
    Signed r = lower_uncached(id);
    memo_[static_cast<std::size_t>(id)] = r;
    return r;
  }

  int materialize(Signed s) { return s.sign > 0 ? s.node : b_.op(BOp::neg, {s.node}); }

  Signed sum_chain(std::vector<Signed> items) {
    if (items.size() == 1) return items[0];
    std::vector<int> pos, neg;
    for (const Signed& s : items) (s.sign > 0 ? pos : neg).push_back(s.node);
    std::sort(pos.begin(), pos.end());
    std::sort(neg.begin(), neg.end());
    int sign = 1;
    if (pos.empty()) {
      std::swap(pos, neg);
      sign = -1;
    }
    int acc = pos[0];
    for (std::size_t i = 1; i < pos.size(); ++i) acc = b_.op(BOp::add, {acc, pos[i]});
    for (int x : neg) acc = b_.op(BOp::sub, {acc, x});
    return {sign, acc};
  }

  int product_chain(std::vector<int> items) {
    std::sort(items.begin(), items.end());
    int acc = items[0];
    for (std::size_t i = 1; i < items.size(); ++i) acc = b_.op(BOp::mul, {acc, items[i]});
    return acc;
  }

  int power(int base, int k) {
    if (k == 1) return base;
    int half = power(base, k / 2);
    int sq = b_.op(BOp::mul, {half, half});
    return (k % 2 == 0) ? sq : b_.op(BOp::mul, {sq, base});
  }

  /**
   * The product of `factors`; when `scaled_input` >= 0 it is a binary node (constant * input)
   * that stands in for the input factor of exponent 1 it replaces.
   */
  Signed lower_product(const std::vector<NFactor>& factors, int scaled_input, int replaced = -1) {
    int sign = 1;
    std::vector<int> num, den;
    for (const NFactor& f : factors) {
      if (f.node == replaced) {
        num.push_back(scaled_input);
        continue;
      }
      Signed l = lower(f.node);
      if (l.sign < 0 && (f.exp % 2 != 0)) sign = -sign;
      int p = power(l.node, std::abs(f.exp));
      (f.exp > 0 ? num : den).push_back(p);
    }
    if (den.empty()) return {sign, product_chain(num)};
    int top = num.empty() ? b_.constant(1.0) : product_chain(num);
    return {sign, b_.op(BOp::div, {top, product_chain(den)})};
  }

  /**
   * magnitude * node (magnitude > 0). When the node is a product with an input factor such as h,
   * the constant multiplies that input (h*0.5), a node that the outputs sharing the same
   * coefficient then share; otherwise it multiplies the whole node. Same operation count.
   */
  Signed lower_scaled(Num magnitude, int id) {
    const NNode& n = n_.nodes[static_cast<std::size_t>(id)];
    if (n.kind == NKind::product) {
      int chosen = -1;
      for (const NFactor& f : n.factors) {
        if (f.exp == 1 && n_.nodes[static_cast<std::size_t>(f.node)].kind == NKind::input) {
          chosen = f.node;
          break;
        }
      }
      if (chosen >= 0) {
        const int leaf = lower(chosen).node;
        const int scaled = b_.op(BOp::mul, {b_.constant(magnitude), leaf});
        return lower_product(n.factors, scaled, chosen);
      }
    }
    Signed l = lower(id);
    return {l.sign, b_.op(BOp::mul, {b_.constant(magnitude), l.node})};
  }

  Signed lower_uncached(int id) {
    const NNode& n = n_.nodes[static_cast<std::size_t>(id)];
    switch (n.kind) {
      case NKind::constant:
        return {n.value.d < 0 ? -1 : 1, b_.constant(abs_of(n.value))};
      case NKind::input: {
        BNode b;
        b.op = BOp::input;
        b.name = n.name;
        b.group = n.group;
        return {1, b_.intern(std::move(b))};
      }
      case NKind::sum: {
        std::map<double, std::vector<Signed>> groups;
        std::map<double, std::vector<int>> sources;  // the n-ary nodes of each group
        std::map<double, Num> magnitudes;            // each group's coefficient with its extended value
        for (const NTerm& t : n.terms) {
          Signed l = lower(t.node);
          const Num c = l.sign < 0 ? -t.coef : t.coef;
          groups[std::fabs(c.d)].push_back({c.d < 0 ? -1 : 1, l.node});
          sources[std::fabs(c.d)].push_back(t.node);
          magnitudes.emplace(std::fabs(c.d), abs_of(c));
        }
        if (n.constant.d != 0)
          groups[1.0].push_back({n.constant.d < 0 ? -1 : 1, b_.constant(abs_of(n.constant))});
        magnitudes.emplace(1.0, Num(1.0));
        std::vector<Signed> parts;
        for (auto& [key, items] : groups) {
          const Num magnitude = magnitudes.at(key);
          if (key != 1 && items.size() == 1) {
            // One scaled term: the coefficient may fold into one of its factors.
            Signed g = lower_scaled(magnitude, sources[key][0]);
            const int sign = items[0].sign * lower(sources[key][0]).sign * g.sign;
            parts.push_back({sign, g.node});
            continue;
          }
          Signed g = sum_chain(items);
          if (key != 1) g.node = b_.op(BOp::mul, {b_.constant(magnitude), g.node});
          parts.push_back(g);
        }
        return sum_chain(parts);
      }
      case NKind::product:
        return lower_product(n.factors, -1);
      case NKind::call: {
        const FunctionInfo* info = function_info(n.name);
        BNode b;
        b.op = BOp::call;
        b.name = n.name;  // printed as info's C or extended-precision function
        int sign = 1;
        if (n.args.size() == 1) {
          Signed a = lower(n.args[0]);
          if (a.sign < 0 && info->parity == 1) {
            sign = -1;
            b.kids = {a.node};
          } else if (a.sign < 0 && info->parity == 2) {
            b.kids = {a.node};
          } else {
            b.kids = {materialize(a)};
          }
        } else {
          for (int a : n.args) b.kids.push_back(materialize(lower(a)));
        }
        return {sign, b_.intern(std::move(b))};
      }
    }
    return {1, b_.constant(0)};
  }

  const NDag& n_;
  BDag& b_;
  std::vector<std::optional<Signed>> memo_;
};

long long tree_ops(const BDag& dag, const std::vector<int>& roots) {
  std::vector<long long> size(dag.nodes.size(), -1);
  std::function<long long(int)> visit = [&](int id) -> long long {
    long long& s = size[static_cast<std::size_t>(id)];
    if (s >= 0) return s;
    const BNode& n = dag.nodes[static_cast<std::size_t>(id)];
    long long total = dag.leaf(id) ? 0 : 1;
    for (int k : n.kids) total = std::min<long long>(total + visit(k), 1LL << 60);
    s = total;
    return s;
  };
  long long total = 0;
  for (int r : roots) total = std::min<long long>(total + visit(r), 1LL << 60);
  return total;
}

class Printer {
 public:
  Printer(const BDag& dag, std::string prefix, bool extended = false)
      : dag_(dag), prefix_(std::move(prefix)), extended_(extended), name_(dag.nodes.size()) {}

  KernelCode emit(const std::vector<std::string>& targets, const std::vector<int>& roots) {
    KernelCode code;
    uses_.assign(dag_.nodes.size(), 0);
    std::vector<char> seen(dag_.nodes.size(), 0);
    std::vector<int> stack;
    for (int r : roots) {
      ++uses_[static_cast<std::size_t>(r)];
      stack.push_back(r);
    }
    while (!stack.empty()) {
      int id = stack.back();
      stack.pop_back();
      if (seen[static_cast<std::size_t>(id)]) continue;
      seen[static_cast<std::size_t>(id)] = 1;
      const BNode& n = dag_.nodes[static_cast<std::size_t>(id)];
      if (!dag_.leaf(id)) ++code.ops_after;
      if (n.op == BOp::input) code.used_groups.insert(n.group);
      for (int k : n.kids) {
        ++uses_[static_cast<std::size_t>(k)];
        stack.push_back(k);
      }
    }
    emitted_.assign(dag_.nodes.size(), 0);
    for (std::size_t i = 0; i < roots.size(); ++i) {
      schedule(roots[i], code);
      code.outputs.push_back({targets[i], print(roots[i]).first});
    }
    return code;
  }

 private:
  bool temporary(int id) const { return !dag_.leaf(id) && uses_[static_cast<std::size_t>(id)] >= 2; }

  void schedule(int id, KernelCode& code) {
    if (emitted_[static_cast<std::size_t>(id)]) return;
    emitted_[static_cast<std::size_t>(id)] = 1;
    for (int k : dag_.nodes[static_cast<std::size_t>(id)].kids) schedule(k, code);
    if (temporary(id)) {
      std::string expr = print(id, true).first;
      char buf[32];
      std::snprintf(buf, sizeof buf, "%04d", ++count_);
      name_[static_cast<std::size_t>(id)] = prefix_ + buf;
      code.temporaries.push_back({name_[static_cast<std::size_t>(id)], expr});
    }
  }

  static int precedence(BOp op) {
    switch (op) {
      case BOp::add:
      case BOp::sub: return 1;
      case BOp::mul:
      case BOp::div: return 2;
      case BOp::neg: return 3;
      default: return 4;
    }
  }

  /** The C text of a node and its precedence; temporaries print as their names. */
  std::pair<std::string, int> print(int id, bool define = false) {
    const std::string& given = name_[static_cast<std::size_t>(id)];
    if (!define && !given.empty()) return {given, 4};
    const BNode& n = dag_.nodes[static_cast<std::size_t>(id)];
    auto wrap = [](const std::pair<std::string, int>& p, bool paren) { return paren ? "(" + p.first + ")" : p.first; };
    switch (n.op) {
      case BOp::constant: {
        std::string s = extended_ ? c_extended_literal(n.value.q) : c_double_literal(n.value.d);
        return {n.value.d < 0 || s[0] == '(' ? "(" + s + ")" : s, 4};
      }
      case BOp::input: return {n.name, 4};
      case BOp::add:
      case BOp::sub:
      case BOp::mul:
      case BOp::div: {
        const int p = precedence(n.op);
        auto l = print(n.kids[0]);
        auto r = print(n.kids[1]);
        const char* sym = n.op == BOp::add ? " + " : n.op == BOp::sub ? " - " : n.op == BOp::mul ? "*" : "/";
        return {wrap(l, l.second < p) + sym + wrap(r, r.second <= p), p};
      }
      case BOp::neg: {
        auto k = print(n.kids[0]);
        return {"-" + wrap(k, k.second < 4), 3};
      }
      case BOp::call: {
        const FunctionInfo* info = function_info(n.name);
        std::string s = std::string(extended_ ? info->quad_name : info->c_name) + "(";
        for (std::size_t i = 0; i < n.kids.size(); ++i) s += (i ? ", " : "") + print(n.kids[i]).first;
        return {s + ")", 4};
      }
    }
    return {"0.0", 4};
  }

  const BDag& dag_;
  std::string prefix_;
  bool extended_ = false;
  std::vector<std::string> name_;
  std::vector<int> uses_;
  std::vector<char> emitted_;
  int count_ = 0;
};

}  // namespace

/**
 * Divisions are several times slower than multiplications: where two or more divisions reachable
 * from the roots share a denominator, the reciprocal of that denominator is computed once and the
 * divisions become multiplications by it (a/h, b/h -> r = 1/h; a*r, b*r).
 */
void share_reciprocals(BDag& dag, const std::vector<int>& roots) {
  std::vector<char> seen(dag.nodes.size(), 0);
  std::vector<int> stack(roots.begin(), roots.end()), divisions;
  while (!stack.empty()) {
    const int id = stack.back();
    stack.pop_back();
    if (seen[static_cast<std::size_t>(id)]) continue;
    seen[static_cast<std::size_t>(id)] = 1;
    const BNode& n = dag.nodes[static_cast<std::size_t>(id)];
    if (n.op == BOp::div) divisions.push_back(id);
    for (int k : n.kids) stack.push_back(k);
  }
  std::sort(divisions.begin(), divisions.end());
  std::map<int, std::vector<int>> by_denominator;
  for (int id : divisions) {
    const BNode& n = dag.nodes[static_cast<std::size_t>(id)];
    if (dag.nodes[static_cast<std::size_t>(n.kids[1])].op == BOp::constant) continue;
    by_denominator[n.kids[1]].push_back(id);
  }
  for (const auto& [denominator, uses] : by_denominator) {
    if (uses.size() < 2) continue;
    const int reciprocal = dag.op(BOp::div, {dag.constant(1.0), denominator});
    for (int id : uses) {
      if (id == reciprocal) continue;
      BNode& n = dag.nodes[static_cast<std::size_t>(id)];
      const int numerator = n.kids[0];
      n.op = BOp::mul;
      n.kids = {numerator, reciprocal};
    }
  }
}

KernelCode generate_kernel_code(const std::vector<KernelOutput>& outputs, const std::vector<KernelInput>& inputs,
                                const CseOptions& options, KernelCode* extended) {
  NDag ndag;
  std::vector<Scaled> roots;
  {
    struct DigitsGuard {
      long saved = GiNaC::Digits;
      DigitsGuard() { GiNaC::Digits = 30; }
      ~DigitsGuard() { GiNaC::Digits = saved; }
    } digits;
    Converter converter(ndag, inputs);
    for (const KernelOutput& out : outputs) {
      Exact x = converter.convert(out.value);
      roots.push_back({num_of(x.coef), x.node});
    }
  }
  rebuild(ndag, roots);
  long long before = 0;
  {
    BDag naive;
    Lowerer lower(ndag, naive);
    std::vector<int> broots;
    for (const Scaled& s : roots) broots.push_back(lower.lower_output(s));
    before = tree_ops(naive, broots);
  }
  rebuild(ndag, roots);
  if (options.factor_sums) factor_pairs(ndag, roots, false, options.max_factoring_rounds);
  if (options.factor_products) factor_pairs(ndag, roots, true, options.max_factoring_rounds);
  if (options.factor_sums) factor_pairs(ndag, roots, false, options.max_factoring_rounds);
  rebuild(ndag, roots);
  BDag bdag;
  Lowerer lower(ndag, bdag);
  std::vector<int> broots;
  std::vector<std::string> targets;
  for (std::size_t i = 0; i < roots.size(); ++i) {
    broots.push_back(lower.lower_output(roots[i]));
    targets.push_back(outputs[i].target);
  }
  share_reciprocals(bdag, broots);
  Printer printer(bdag, options.temp_prefix);
  KernelCode code = printer.emit(targets, broots);
  code.ops_before = before;
  if (extended) {
    Printer wide(bdag, options.temp_prefix, true);
    *extended = wide.emit(targets, broots);
    extended->ops_before = before;
  }
  return code;
}

}  // namespace pardel_codegen

/**
 * @file cse_nary_dag.cpp
 * The n-ary DAG of the CSE: structural hashing independent of node ids and of GiNaC's term
 * order, hash-consing, in-place rewriting, and the rebuild that re-interns the reachable part.
 */
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>

#include "cse_nary.hpp"

namespace pardel_codegen::cse {
namespace {

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

}  // namespace

void NDag::canonicalize(NNode& n) const {
  std::sort(n.terms.begin(), n.terms.end(), [&](const NTerm& x, const NTerm& y) {
    if (shash(x.node) != shash(y.node)) return shash(x.node) < shash(y.node);
    return x.coef.d < y.coef.d;
  });
  std::sort(n.factors.begin(), n.factors.end(), [&](const NFactor& x, const NFactor& y) {
    if (shash(x.node) != shash(y.node)) return shash(x.node) < shash(y.node);
    return x.exp < y.exp;
  });
}

std::uint64_t NDag::structural_hash(const NNode& n) const {
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

std::string NDag::key_of(const NNode& n) {
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

int NDag::intern(NNode n) {
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

void NDag::rewrite(int id, NNode replacement) {
  canonicalize(replacement);
  replacement.shash = nodes[static_cast<std::size_t>(id)].shash;
  std::string old_key = key_of(nodes[static_cast<std::size_t>(id)]);
  auto it = table_.find(old_key);
  if (it != table_.end() && it->second == id) table_.erase(it);
  nodes[static_cast<std::size_t>(id)] = std::move(replacement);
  table_.emplace(key_of(nodes[static_cast<std::size_t>(id)]), id);
}

int NDag::constant(Num v) {
  NNode n;
  n.kind = NKind::constant;
  n.value = v;
  return intern(std::move(n));
}

int NDag::materialize(Scaled s) {
  if (s.node < 0) return constant(s.coef);
  if (s.coef.d == 1) return s.node;
  NNode n;
  n.kind = NKind::sum;
  n.terms.push_back(NTerm{s.coef, s.node});
  return intern(std::move(n));
}

Exact NDag::make_sum(const std::vector<std::pair<GiNaC::ex, int>>& raw, const GiNaC::ex& constant_term) {
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

Exact NDag::make_product(const GiNaC::ex& coef, const std::map<int, int>& raw) {
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

void NDag::add_factor(std::map<int, int>& factors, int node, int e) {
  const NNode& n = nodes[static_cast<std::size_t>(node)];
  if (n.kind == NKind::product) {
    std::vector<NFactor> inner = n.factors;
    for (const NFactor& f : inner) factors[f.node] += f.exp * e;
  } else {
    factors[node] += e;
  }
}

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

}  // namespace pardel_codegen::cse

/**
 * @file cse_binary.cpp
 * The binary DAG of the CSE and the passes over it: the lowering of the n-ary DAG (equal
 * coefficients grouped, negations folded into subtractions and through odd and even functions,
 * integer powers by squaring), the count of operations without sharing, and the sharing of
 * reciprocals of common denominators.
 */
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>

#include "cse_binary.hpp"

namespace pardel_codegen::cse {

int BDag::intern(BNode n) {
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

int BDag::op(BOp o, std::vector<int> kids) {
  BNode n;
  n.op = o;
  n.kids = std::move(kids);
  return intern(std::move(n));
}

int BDag::constant(Num v) {
  BNode n;
  n.op = BOp::constant;
  n.value = v;
  return intern(std::move(n));
}

bool BDag::leaf(int id) const {
  BOp o = nodes[static_cast<std::size_t>(id)].op;
  return o == BOp::constant || o == BOp::input;
}

int Lowerer::lower_output(const Scaled& s) {
  if (s.node < 0) return b_.constant(s.coef);
  const Num magnitude = abs_of(s.coef);
  Signed l = magnitude.d == 1 ? lower(s.node) : lower_scaled(magnitude, s.node);
  const int sign = (s.coef.d < 0 ? -1 : 1) * l.sign;
  return sign > 0 ? l.node : b_.op(BOp::neg, {l.node});
}

Signed Lowerer::lower(int id) {
  if (memo_[static_cast<std::size_t>(id)]) return *memo_[static_cast<std::size_t>(id)];
  Signed r = lower_uncached(id);
  memo_[static_cast<std::size_t>(id)] = r;
  return r;
}

Signed Lowerer::sum_chain(std::vector<Signed> items) {
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

int Lowerer::product_chain(std::vector<int> items) {
  std::sort(items.begin(), items.end());
  int acc = items[0];
  for (std::size_t i = 1; i < items.size(); ++i) acc = b_.op(BOp::mul, {acc, items[i]});
  return acc;
}

int Lowerer::power(int base, int k) {
  if (k == 1) return base;
  int half = power(base, k / 2);
  int sq = b_.op(BOp::mul, {half, half});
  return (k % 2 == 0) ? sq : b_.op(BOp::mul, {sq, base});
}

Signed Lowerer::lower_product(const std::vector<NFactor>& factors, int scaled_input, int replaced) {
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

Signed Lowerer::lower_scaled(Num magnitude, int id) {
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

Signed Lowerer::lower_uncached(int id) {
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

}  // namespace pardel_codegen::cse

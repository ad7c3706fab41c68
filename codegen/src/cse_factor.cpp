/**
 * @file cse_factor.cpp
 * The factoring pass of the CSE: pairs of terms (sums) or factors (products) that two or more
 * nodes of the n-ary DAG share are factored out greedily, the most shared pair first, round after
 * round until no pair is shared.
 */
#include <algorithm>
#include <functional>
#include <numeric>

#include "cse_nary.hpp"

namespace pardel_codegen::cse {
namespace {

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

using Holders = std::unordered_map<PairKey, std::vector<int>, PairKeyHash>;
using Candidates = std::vector<std::pair<PairKey, const std::vector<int>*>>;

/** Every pair of distinct terms of the live sums (factors of the live products when `products`),
 *  with the nodes that hold it. */
Holders collect_pairs(const NDag& dag, const std::vector<char>& live, bool products) {
  const NKind kind = products ? NKind::product : NKind::sum;
  Holders holders;
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
  return holders;
}

/** The pairs held by two or more nodes, most holders first, ties broken by structure. */
Candidates ranked_candidates(const NDag& dag, const Holders& holders) {
  Candidates candidates;
  for (const auto& [key, ids] : holders) {
    if (ids.size() >= 2) candidates.emplace_back(key, &ids);
  }
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
  return candidates;
}

/** The nodes among `ids` that still hold the pair `key` after this round's earlier rewrites;
 *  `ratio` receives a sum pair's ratio with its extended-precision value, from the first holder. */
std::vector<int> current_holders(const NDag& dag, const PairKey& key, const std::vector<int>& ids, bool products,
                                 Num& ratio) {
  std::vector<int> hits;
  for (int id : ids) {
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
        hits.push_back(id);
      }
    } else {
      const NFactor* fa = nullptr;
      const NFactor* fb = nullptr;
      for (const NFactor& f : n.factors) {
        if (f.node == key.a) fa = &f;
        if (f.node == key.b) fb = &f;
      }
      if (fa && fb && product_key(*fa, *fb) == key) hits.push_back(id);
    }
  }
  return hits;
}

/** Rewrites node `id` with the pair `key` replaced by the node `s` that computes it. */
void replace_pair(NDag& dag, int id, const PairKey& key, int s, bool products) {
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
}

/** Factors the pair `key` out of the nodes among `ids` that still hold it; true when a node changed. */
bool factor_pair(NDag& dag, const PairKey& key, const std::vector<int>& ids, bool products) {
  const NKind kind = products ? NKind::product : NKind::sum;
  Num ratio = key.r;  // the ratio with its extended-precision value, from the first holder
  const std::vector<int> hits = current_holders(dag, key, ids, products, ratio);
  if (hits.size() < 2) return false;
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
  bool changed = false;
  for (int id : hits) {
    if (id == s) continue;
    replace_pair(dag, id, key, s, products);
    changed = true;
  }
  return changed;
}

}  // namespace

int factor_pairs(NDag& dag, std::vector<Scaled>& roots, bool products, int max_rounds) {
  int rounds = 0;
  for (; rounds < max_rounds; ++rounds) {
    rebuild(dag, roots);
    std::vector<char> live = reachable(dag, roots);
    const Holders holders = collect_pairs(dag, live, products);
    const Candidates candidates = ranked_candidates(dag, holders);
    if (candidates.empty()) break;
    bool changed = false;
    for (const auto& [key, ids] : candidates) {
      if (factor_pair(dag, key, *ids, products)) changed = true;
    }
    if (!changed) break;
  }
  return rounds;
}

}  // namespace pardel_codegen::cse

/**
 * @file cse_nary.hpp
 * Internal to the CSE (cse.hpp): the n-ary DAG (hash-consed sums with coefficients, products with
 * integer exponents, function calls), the conversion of GiNaC expressions into it, and the
 * factoring of shared sub-sums and sub-products.
 */
#ifndef PARDEL_CODEGEN_SRC_CSE_NARY_HPP
#define PARDEL_CODEGEN_SRC_CSE_NARY_HPP

#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cse_numbers.hpp"

namespace pardel_codegen::cse {

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

/** The n-ary DAG, hash-consed by content (cse_nary_dag.cpp). */
class NDag {
 public:
  std::vector<NNode> nodes;

  std::uint64_t shash(int id) const { return nodes[static_cast<std::size_t>(id)].shash; }

  /** Sorts terms and factors by the structural hash of their nodes (then coefficient). */
  void canonicalize(NNode& n) const;
  std::uint64_t structural_hash(const NNode& n) const;
  static std::string key_of(const NNode& n);
  int intern(NNode n);
  /** Replaces the contents of node `id` (the factoring passes rewrite sums and products in place). */
  void rewrite(int id, NNode replacement);
  int constant(Num v);
  int materialize(Scaled s);
  /**
   * A sum of exact coefficient * node terms plus an exact constant. A common sign, or a common
   * magnitude of all coefficients, is pulled out and returned as the scale.
   */
  Exact make_sum(const std::vector<std::pair<GiNaC::ex, int>>& raw, const GiNaC::ex& constant_term);
  Exact make_product(const GiNaC::ex& coef, const std::map<int, int>& raw);
  /** Adds node^e to a product's factors, flattening nested products. */
  void add_factor(std::map<int, int>& factors, int node, int e);

 private:
  std::unordered_map<std::string, int> table_;
};

/** The nodes reachable from `roots`. */
std::vector<char> reachable(const NDag& dag, const std::vector<Scaled>& roots);

/**
 * Copies the part of `dag` reachable from `roots` into a fresh DAG, interning every node by its
 * content: duplicates left by in-place rewrites merge, identity sums and products collapse, and
 * node ids and structural hashes become functions of the content alone (so of nothing that
 * varies between runs).
 */
void rebuild(NDag& dag, std::vector<Scaled>& roots);

/** GiNaC -> n-ary DAG (cse_convert.cpp). */
class Converter {
 public:
  Converter(NDag& dag, const std::vector<KernelInput>& inputs) : dag_(dag) {
    for (const KernelInput& in : inputs) inputs_.emplace(in.symbol, &in);
  }

  Exact convert(const GiNaC::ex& e);

  /** The node of a converted value (a constant node, the node itself, or a scaled node). */
  int materialize(const Exact& x);

 private:
  static std::string to_string(const GiNaC::ex& e);
  static bool small_integer(const GiNaC::ex& e, int* out);
  Exact power_of(const Exact& base, int k);
  Exact convert_composite(const GiNaC::ex& e);
  Exact convert_sum(const GiNaC::ex& e);
  Exact convert_product(const GiNaC::ex& e);
  Exact convert_power(const GiNaC::ex& e);
  Exact convert_call(const GiNaC::ex& e);

  NDag& dag_;
  std::map<GiNaC::ex, const KernelInput*, GiNaC::ex_is_less> inputs_;
  /** Keyed by value (the map holds the expressions, so keys stay valid). */
  std::map<GiNaC::ex, Exact, GiNaC::ex_is_less> memo_;
};

/** Factors sub-sums (products when `products`) shared by two or more nodes; returns rounds used
 *  (cse_factor.cpp). */
int factor_pairs(NDag& dag, std::vector<Scaled>& roots, bool products, int max_rounds);

}  // namespace pardel_codegen::cse

#endif  // PARDEL_CODEGEN_SRC_CSE_NARY_HPP

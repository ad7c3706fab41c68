/**
 * @file cse_binary.hpp
 * Internal to the CSE (cse.hpp): the binary DAG (one operation per node, hash-consed), the
 * lowering of the n-ary DAG into it, the reciprocal sharing, and the printer of C code.
 */
#ifndef PARDEL_CODEGEN_SRC_CSE_BINARY_HPP
#define PARDEL_CODEGEN_SRC_CSE_BINARY_HPP

#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cse_nary.hpp"

namespace pardel_codegen::cse {

enum class BOp { constant, input, add, sub, mul, div, neg, call };

struct BNode {
  BOp op = BOp::constant;
  Num value = 0;
  std::string name;  ///< input: C name; call: C function name
  std::string group; ///< input: kernel argument
  std::vector<int> kids;
};

/** The binary DAG, hash-consed by content (cse_binary.cpp). */
class BDag {
 public:
  std::vector<BNode> nodes;

  int intern(BNode n);
  int op(BOp o, std::vector<int> kids);
  int constant(Num v);
  bool leaf(int id) const;

 private:
  std::unordered_map<std::string, int> table_;
};

struct Signed {
  int sign;
  int node;
};

/** The lowering of the n-ary DAG into binary operations (cse_binary.cpp). */
class Lowerer {
 public:
  Lowerer(const NDag& n, BDag& b) : n_(n), b_(b), memo_(n.nodes.size()) {}

  /** The binary node of an output value coef * node (node < 0: a constant). */
  int lower_output(const Scaled& s);

 private:
  Signed lower(int id);

  int materialize(Signed s) { return s.sign > 0 ? s.node : b_.op(BOp::neg, {s.node}); }

  Signed sum_chain(std::vector<Signed> items);
  int product_chain(std::vector<int> items);
  int power(int base, int k);
  /**
   * The product of `factors`; when `scaled_input` >= 0 it is a binary node (constant * input)
   * that stands in for the input factor of exponent 1 it replaces.
   */
  Signed lower_product(const std::vector<NFactor>& factors, int scaled_input, int replaced = -1);
  /**
   * magnitude * node (magnitude > 0). When the node is a product with an input factor such as h,
   * the constant multiplies that input (h*0.5), a node that the outputs sharing the same
   * coefficient then share; otherwise it multiplies the whole node. Same operation count.
   */
  Signed lower_scaled(Num magnitude, int id);
  Signed lower_uncached(int id);

  const NDag& n_;
  BDag& b_;
  std::vector<std::optional<Signed>> memo_;
};

/** The operations of the outputs printed as trees, without sharing. */
long long tree_ops(const BDag& dag, const std::vector<int>& roots);

/**
 * Divisions are several times slower than multiplications: where two or more divisions reachable
 * from the roots share a denominator, the reciprocal of that denominator is computed once and the
 * divisions become multiplications by it (a/h, b/h -> r = 1/h; a*r, b*r).
 */
void share_reciprocals(BDag& dag, const std::vector<int>& roots);

/** The printer of straight-line C: temporaries for nodes used twice and for every function call,
 *  in evaluation order (cse_print.cpp). All temporaries precede the stores to the outputs, so a
 *  compiler sees every call's argument before any store that might alias the inputs, and can pair
 *  sin and cos of one argument into one sincos. */
class Printer {
 public:
  Printer(const BDag& dag, std::string prefix, bool extended = false)
      : dag_(dag), prefix_(std::move(prefix)), extended_(extended), name_(dag.nodes.size()) {}

  KernelCode emit(const std::vector<std::string>& targets, const std::vector<int>& roots);

 private:
  bool temporary(int id) const {
    return !dag_.leaf(id) &&
           (uses_[static_cast<std::size_t>(id)] >= 2 || dag_.nodes[static_cast<std::size_t>(id)].op == BOp::call);
  }

  void schedule(int id, KernelCode& code);
  static int precedence(BOp op);
  /** The C text of a node and its precedence; temporaries print as their names. */
  std::pair<std::string, int> print(int id, bool define = false);

  const BDag& dag_;
  std::string prefix_;
  bool extended_ = false;
  std::vector<std::string> name_;
  std::vector<int> uses_;
  std::vector<char> emitted_;
  int count_ = 0;
};

}  // namespace pardel_codegen::cse

#endif  // PARDEL_CODEGEN_SRC_CSE_BINARY_HPP

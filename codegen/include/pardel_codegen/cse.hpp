/**
 * @file cse.hpp
 * Common-subexpression elimination and C printing of a set of GiNaC expressions that one
 * generated kernel computes together.
 *
 * The expressions are hash-consed into an n-ary DAG (sums with coefficients, products with
 * integer exponents, function calls); shared sub-sums and sub-products are factored out
 * greedily, pair by pair; the DAG is then lowered to binary operations (integer powers by
 * squaring, negations folded into subtractions, equal coefficients grouped) and hash-consed
 * again. Every node used twice becomes a temporary `pd_tNNNN`; inputs are printed through the
 * caller's names (q0[3], p[0], h), so no name from the .lag can reach the output.
 *
 * Operation count convention: each binary + - * /, each unary minus and each function call is
 * one operation; reading an input or a constant is free.
 */
#ifndef PARDEL_CODEGEN_CSE_HPP
#define PARDEL_CODEGEN_CSE_HPP

#include <ginac/ginac.h>

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace pardel_codegen {

/** An expression that cannot be emitted (complex or non-finite constant, unknown function). */
class CodegenError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/** Whether `error` is GiNaC's objection to arithmetic on a model's expressions (a
 *  std::runtime_error such as "power::eval(): division by zero" for a zero base raised to a
 *  negative power, or GiNaC::pole_error, a std::domain_error, for a derivative at a singularity)
 *  rather than a CodegenError or a defect. */
inline bool symbolic_arithmetic_error(const std::exception& error) {
  return dynamic_cast<const CodegenError*>(&error) == nullptr &&
         (dynamic_cast<const std::runtime_error*>(&error) != nullptr ||
          dynamic_cast<const std::domain_error*>(&error) != nullptr);
}

/** The extended precision of the kernels that evaluate the DEL residual past double precision:
 *  GCC's __float128 (113-bit significand) where the compiler has it, else long double. */
#if defined(__SIZEOF_FLOAT128__)
using ExtendedFloat = __float128;
#else
using ExtendedFloat = long double;
#endif

/** A symbol the kernel reads: its C spelling and the kernel argument it belongs to. */
struct KernelInput {
  GiNaC::symbol symbol;
  std::string c_name;  ///< e.g. "q0[3]", "p[0]", "h"
  std::string group;   ///< the kernel argument: "q0", "p", "h", ...
};

/** One value the kernel writes: `target = value;` (target "return" for returned values). */
struct KernelOutput {
  std::string target;
  GiNaC::ex value;
};

/** A C assignment `name = expr`. */
struct Assignment {
  std::string name;
  std::string expr;
};

/** The straight-line code of one kernel. */
struct KernelCode {
  std::vector<Assignment> temporaries;  ///< `const double name = expr;`, in evaluation order
  std::vector<Assignment> outputs;      ///< `target = expr;`, in the order given
  long long ops_before = 0;             ///< operations of the outputs printed as trees, no sharing
  long long ops_after = 0;              ///< operations of the emitted code
  std::set<std::string> used_groups;    ///< the input groups the code reads
};

/** Switches of the optimizer (all on by default; tests turn them off to compare). */
struct CseOptions {
  bool factor_sums = true;      ///< factor sub-sums shared by several sums
  bool factor_products = true;  ///< factor sub-products shared by several products
  int max_factoring_rounds = 20000;
  std::string temp_prefix = "pd_t";
};

/**
 * Generates the code computing every output. Deterministic: the same inputs give the same text.
 * When `extended` is given it receives the same code printed for extended precision: temporaries
 * of type pd_quad, constants by c_extended_literal (each the exact constant rounded once to
 * extended precision, not the double's value widened), functions from libquadmath (sinq, ...).
 * Every decision of the optimizer reads the double values, so the double code is the same either way.
 * @throws CodegenError when an expression cannot be printed as real double arithmetic.
 */
KernelCode generate_kernel_code(const std::vector<KernelOutput>& outputs, const std::vector<KernelInput>& inputs,
                                const CseOptions& options = CseOptions(), KernelCode* extended = nullptr);

/** A double as a C literal with 17 significant digits (always with '.' or an exponent). */
std::string c_double_literal(double value);

/** True when a number in `e` is beyond 1e300 in magnitude: GiNaC's evalf of functions of such
 *  numbers is not reliable (exp(10^308) evaluates to 1.0), and no double kernel needs them. The
 *  .lag reader refuses such a param default, the CSE such a constant. */
bool has_huge_number(const GiNaC::ex& e);

/** An extended-precision value as a C++ expression of type pd_quad that needs no compiler flag:
 *  the sum of up to three doubles, `(pd_quad(0.33333333333333331) + 1.8503717077085941e-17 +
 *  1.0271626370065257e-33)`, whose sum in pd_quad is the value (a value that is a double prints
 *  as that double's literal). No Q-suffixed literal: ISO C++ (-std=c++17) reads the suffix as a
 *  user-defined literal unless -fext-numeric-literals is given. */
std::string c_extended_literal(ExtendedFloat value);

}  // namespace pardel_codegen

#endif  // PARDEL_CODEGEN_CSE_HPP

/**
 * @file cse_numbers.hpp
 * Internal to the CSE (cse.hpp): its constants, a double beside the same value in extended
 * precision, and the functions the generator can emit.
 */
#ifndef PARDEL_CODEGEN_SRC_CSE_NUMBERS_HPP
#define PARDEL_CODEGEN_SRC_CSE_NUMBERS_HPP

#include <string>

#include "pardel_codegen/cse.hpp"

namespace pardel_codegen::cse {

/** A double in C's %a notation (exact; used in the keys of hash-consing). */
std::string hex(double v);

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
inline Num operator+(const Num& a, const Num& b) { return {a.d + b.d, a.q + b.q}; }
inline Num operator/(const Num& a, const Num& b) { return {a.d / b.d, a.q / b.q}; }
inline Num operator-(const Num& a) { return {-a.d, -a.q}; }
inline Num& operator+=(Num& a, const Num& b) { return a = a + b; }
inline Num abs_of(const Num& a) { return a.d < 0 ? -a : a; }

/** A constant expression rounded once to double (GiNaC::Digits is raised while generating). */
double value_of(const GiNaC::ex& c);

/** A constant expression rounded once to double, and to extended precision (the sum of up to three
 *  doubles taken from an evaluation at 60 digits: a correctly rounded __float128 up to its last
 *  bit). */
Num num_of(const GiNaC::ex& c);

/** A function the generator can emit. */
struct FunctionInfo {
  const char* c_name;
  const char* quad_name;  ///< the libquadmath function of the extended-precision kernels
  int arity;
  int parity;  ///< 1: odd, f(-x) = -f(x); 2: even, f(-x) = f(x); 0: neither
  double (*fold1)(double);
  double (*fold2)(double, double);
};

/** The function called `name` (GiNaC's name), or nullptr when it cannot be emitted. */
const FunctionInfo* function_info(const std::string& name);

}  // namespace pardel_codegen::cse

#endif  // PARDEL_CODEGEN_SRC_CSE_NUMBERS_HPP

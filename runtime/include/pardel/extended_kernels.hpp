/**
 * @file extended_kernels.hpp
 * The arithmetic of the extended-precision kernels that pardel-gen generates (grad_extended,
 * full_extended; pardel/kernel_abi.h), included by the generated model sources: pd_quad is
 * __float128 with libquadmath's functions where the compiler has both (GCC), else long double with
 * the std:: functions under libquadmath's names (clang has __float128 but not quadmath.h); pd_split
 * writes extended values as double-double pairs. A CUDA compiler leaves the extended kernels out,
 * and this header is empty there.
 */
#ifndef PARDEL_EXTENDED_KERNELS_HPP
#define PARDEL_EXTENDED_KERNELS_HPP

#include <cmath>

#if !defined(__CUDACC__)
#if defined(__SIZEOF_FLOAT128__) && defined(__has_include)
#if __has_include(<quadmath.h>)
#define PD_HAVE_QUADMATH 1
#endif
#endif
#if defined(PD_HAVE_QUADMATH)
#include <quadmath.h>
typedef __float128 pd_quad;
#else
typedef long double pd_quad;
static inline pd_quad sinq(pd_quad x) { return std::sin(x); }
static inline pd_quad cosq(pd_quad x) { return std::cos(x); }
static inline pd_quad tanq(pd_quad x) { return std::tan(x); }
static inline pd_quad expq(pd_quad x) { return std::exp(x); }
static inline pd_quad logq(pd_quad x) { return std::log(x); }
static inline pd_quad sqrtq(pd_quad x) { return std::sqrt(x); }
static inline pd_quad sinhq(pd_quad x) { return std::sinh(x); }
static inline pd_quad coshq(pd_quad x) { return std::cosh(x); }
static inline pd_quad tanhq(pd_quad x) { return std::tanh(x); }
static inline pd_quad asinq(pd_quad x) { return std::asin(x); }
static inline pd_quad acosq(pd_quad x) { return std::acos(x); }
static inline pd_quad atanq(pd_quad x) { return std::atan(x); }
static inline pd_quad atan2q(pd_quad y, pd_quad x) { return std::atan2(y, x); }
static inline pd_quad powq(pd_quad x, pd_quad y) { return std::pow(x, y); }
#endif

/** Writes n extended values as double-double pairs out[2i] + out[2i+1]. */
static inline void pd_split(const pd_quad* v, double* out, int n) {
  for (int i = 0; i < n; ++i) {
    out[2 * i] = static_cast<double>(v[i]);
    out[2 * i + 1] = static_cast<double>(v[i] - static_cast<pd_quad>(out[2 * i]));
  }
}
#endif

#endif  // PARDEL_EXTENDED_KERNELS_HPP

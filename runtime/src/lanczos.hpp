/**
 * @file lanczos.hpp
 * The step of the Lanczos three-term recurrence that the point assessment (Lanczos on H^-1 for the
 * smallest eigenvalues, assessment.cpp) and the certificate (Lanczos on L^-1 C L^-T for the Jacobi
 * spectral radius, certificate.cpp) share, in two passes over the vectors.
 */
#ifndef PARDEL_RUNTIME_LANCZOS_HPP
#define PARDEL_RUNTIME_LANCZOS_HPP

#include <cstddef>

namespace pardel::detail {

/** alpha_j and |W|^2 of one Lanczos step. */
struct LanczosStep {
  double alpha = 0, norm2 = 0;
};

/**
 * Given next = A v_j, makes next the residual W = A v_j - beta_{j-1} v_{j-1} - alpha_j v_j, alpha_j =
 * v_j.(A v_j - beta_{j-1} v_{j-1}), in two passes: the first removes v_{j-1} and forms alpha_j, the
 * second removes alpha_j v_j and forms |W|^2. Components with free[i] == 0 (free not null) are set
 * to zero. `reduce(values, count)` sums partial sums over MPI ranks in place (nothing in one
 * process). At the first step, with b_prev = 0, prev may be any finite vector (cur, say).
 */
template <class Reduce>
LanczosStep lanczos_recurrence(std::size_t n, const unsigned char* free, const double* prev, double b_prev,
                               const double* cur, double* next, Reduce&& reduce) {
  LanczosStep step;
  double a = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double w = free && !free[i] ? 0.0 : next[i] - b_prev * prev[i];
    next[i] = w;
    a += cur[i] * w;
  }
  reduce(&a, 1);
  double bb = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double w = next[i] - a * cur[i];
    next[i] = w;
    bb += w * w;
  }
  reduce(&bb, 1);
  step.alpha = a;
  step.norm2 = bb;
  return step;
}

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_LANCZOS_HPP

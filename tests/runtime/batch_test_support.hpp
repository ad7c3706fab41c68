/**
 * @file batch_test_support.hpp
 * What the tests of the device solvers' host paths (test_batch_sweep.cpp, test_batch_newton.cpp)
 * share: a problem on a uniform grid, a batch in flat arrays, one of its problems for solve(), a
 * device status as a pardel::Termination, and random wiggly guesses between random end points.
 */
#ifndef PARDEL_TESTS_BATCH_TEST_SUPPORT_HPP
#define PARDEL_TESTS_BATCH_TEST_SUPPORT_HPP

#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "batch_sweep.hpp"
#include "pardel/pardel.hpp"

namespace batch_test {

/** A problem of model m's first discretization on a uniform grid from t = 0. */
inline pardel::Problem problem_of(const pardel_model& m, double T, int N, std::vector<double> q0,
                                  std::vector<double> qN) {
  pardel::Problem p;
  p.model = &m;
  p.discretization = &m.discretizations[0];
  p.T = T;
  p.N = N;
  p.q0 = std::move(q0);
  p.qN = std::move(qN);
  return p;
}

/** A batch as the host paths take it: the guesses (with their boundary values) and params of B
 *  problems in flat arrays, and the shared uniform grid's node times and steps. */
struct FlatBatch {
  std::vector<double> q, p, t, h;
};
inline FlatBatch flatten(const pardel::Problem& base, const std::vector<pardel::Trajectory>& guesses,
                         const std::vector<std::vector<double>>& params) {
  const std::size_t B = guesses.size(), N = static_cast<std::size_t>(base.N);
  const std::size_t per = (N + 1) * static_cast<std::size_t>(base.model->dim), np = base.model->nparams;
  FlatBatch f;
  f.q.resize(B * per);
  f.p.resize(B * np);
  for (std::size_t b = 0; b < B; ++b) {
    std::copy(guesses[b].q.begin(), guesses[b].q.end(), f.q.begin() + static_cast<long>(b * per));
    std::copy(params[b].begin(), params[b].end(), f.p.begin() + static_cast<long>(b * np));
  }
  f.t.resize(N + 1);
  f.h.assign(N, base.T / base.N);
  for (std::size_t k = 0; k <= N; ++k) f.t[k] = base.t0 + base.T * static_cast<double>(k) / base.N;
  f.t[N] = base.t0 + base.T;
  return f;
}

/** Problem b of a batch for solve(): the base problem with the guess's end points and params. */
inline pardel::Problem entry_of(const pardel::Problem& base, const pardel::Trajectory& guess,
                                const std::vector<double>& params) {
  const int D = base.model->dim;
  pardel::Problem problem = base;
  problem.params = params;
  problem.q0.assign(guess.q.begin(), guess.q.begin() + D);
  problem.qN.assign(guess.q.end() - D, guess.q.end());
  return problem;
}

/** A batch_sweep::Status as the CPU solver's termination. */
inline pardel::Termination termination_of(int status) {
  namespace bs = pardel::batch_sweep;
  switch (status) {
    case bs::converged: return pardel::Termination::converged;
    case bs::max_iterations: return pardel::Termination::max_iterations;
    case bs::diverged: return pardel::Termination::diverged;
    case bs::stalled: return pardel::Termination::stalled;
    default: return pardel::Termination::non_finite;
  }
}

/** Random wiggly guesses between random end points (the boundary values at nodes 0 and N). */
inline std::vector<pardel::Trajectory> wiggly_guesses(const pardel::Problem& base, int B, double spread,
                                                      double amplitude, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<pardel::Trajectory> out;
  const int D = base.model->dim;
  for (int b = 0; b < B; ++b) {
    pardel::Problem p = base;
    for (int i = 0; i < D; ++i) {
      p.q0[i] += spread * u(rng);
      p.qN[i] += spread * u(rng);
    }
    pardel::Trajectory tr = pardel::linear_guess(p);
    const double phase = 3 * u(rng), a = amplitude * u(rng);
    for (int k = 1; k < p.N; ++k)
      for (int i = 0; i < D; ++i) tr.q[k * D + i] += a * std::sin(M_PI * k / p.N) * std::cos(phase + i);
    out.push_back(tr);
  }
  return out;
}

}  // namespace batch_test

#endif  // PARDEL_TESTS_BATCH_TEST_SUPPORT_HPP

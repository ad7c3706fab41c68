/**
 * @file test_batch_sweep.cpp
 * The host path of the device sweeps (runtime/cuda/batch_sweep.hpp: one node's update and one
 * problem's decision, run here in plain loops by host_sweeps) against solve() with the same
 * options, on test models no bundled example resembles: a channel with a logarithmic barrier
 * (dimension 2, params), a hardening spring (dimension 1), a double swing (midpoint, dimension 2)
 * and minimum acceleration in space (order 2, dimension 6: the pivoted LU of larger blocks).
 * Iterates after a few sweeps, converged answers, iteration counts and statuses must agree.
 */
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "barrier_channel.hpp"
#include "batch_test_support.hpp"
#include "batch_sweep.hpp"
#include "double_swing.hpp"
#include "hardening_spring.hpp"
#include "min_accel3.hpp"
#include "pardel/pardel.hpp"

namespace {

using batch_test::problem_of;
using batch_test::termination_of;
using batch_test::wiggly_guesses;

namespace bs = pardel::batch_sweep;

#define PARDEL_SWEEP_OF(Type, symbol)                                                                       \
  struct Type {                                                                                             \
    static void sweep(double h, double t0, double t1, const double* q0, const double* q1, const double* p,  \
                      double* D1, double* D2, double* D11, double* D22) {                                   \
      symbol(h, t0, t1, q0, q1, p, D1, D2, D11, D22);                                                       \
    }                                                                                                       \
  };
PARDEL_SWEEP_OF(Channel, barrier_channel_trapezoid_sweep)
PARDEL_SWEEP_OF(Spring, hardening_spring_trapezoid_sweep)
PARDEL_SWEEP_OF(Swing, double_swing_midpoint_sweep)
PARDEL_SWEEP_OF(Accel, min_accel3_trapezoid_alpha_1_sweep)
#undef PARDEL_SWEEP_OF

/** Each problem (a guess holding its boundary values, params) by solve() and by host_sweeps. */
template <class Kernel, int D>
void compare(const pardel::Problem& base, const std::vector<pardel::Trajectory>& guesses,
             const std::vector<std::vector<double>>& params, const pardel::Options& options, double tolerance) {
  const int B = static_cast<int>(guesses.size()), N = base.N;
  const int np = base.model->nparams;
  const std::size_t per = static_cast<std::size_t>(N + 1) * D;
  batch_test::FlatBatch f = batch_test::flatten(base, guesses, params);
  std::vector<double>& q0 = f.q;  // the guesses, then the iterates of even sweeps
  std::vector<double> q1(B * per);
  const std::vector<double>&p = f.p, &t = f.t, &h = f.h;
  bs::Settings set;
  set.keep = 1 - options.damping;
  set.steps = options.newton_substeps;
  set.nonlinear = options.method == pardel::Method::jacobi;
  set.tol = options.tol;
  set.rtol = options.rtol;
  set.max_iterations = options.max_iterations;
  set.divergence_factor = options.divergence_factor;
  std::vector<bs::ProblemState<D>> state(B);
  bs::host_sweeps<Kernel, D>(B, N, q0.data(), q1.data(), t.data(), h.data(), p.data(), np, set, state.data());
  for (int b = 0; b < B; ++b) {
    const pardel::Problem problem = batch_test::entry_of(base, guesses[b], params[b]);
    pardel::Trajectory tr = guesses[b];
    const pardel::Summary s = pardel::solve(problem, options, tr);
    SCOPED_TRACE("problem " + std::to_string(b) + ": " + s.message);
    EXPECT_EQ(termination_of(state[b].status), s.termination);
    EXPECT_EQ(state[b].iterations, s.iterations);
    const double* mine = (state[b].answer == 0 ? q0 : q1).data() + b * per;
    double diff = 0, size = 0;
    for (std::size_t i = 0; i < per; ++i) {
      diff = std::max(diff, std::fabs(mine[i] - tr.q[i]));
      size = std::max(size, std::fabs(tr.q[i]));
    }
    EXPECT_LE(diff, tolerance * (1 + size));
    if (s.converged()) EXPECT_LE(state[b].residual, s.tolerance);
  }
}

pardel::Options jacobi_newton_options(long max_iterations) {
  pardel::Options o;
  o.method = pardel::Method::jacobi_newton;
  o.threads = 1;
  o.error_estimate = false;
  o.iterative_refinement = pardel::Refinement::off;
  o.max_iterations = max_iterations;
  return o;
}

TEST(BatchSweepHostPath, ChannelIteratesAfterFewSweepsAndConvergedAnswers) {
  const pardel::Problem base = problem_of(barrier_channel_model, 1.5, 24, {-0.3, 0}, {0.4, 1});
  const auto guesses = wiggly_guesses(base, 6, 0.2, 0.3, 7);
  std::vector<std::vector<double>> params;
  for (int b = 0; b < 6; ++b) params.push_back({0.3 - 0.1 * b, -0.5 + 0.2 * b, 0.02 * b});
  compare<Channel, 2>(base, guesses, params, jacobi_newton_options(5), 1e-12);   // iterates
  compare<Channel, 2>(base, guesses, params, jacobi_newton_options(20000), 1e-12);  // to the end
  pardel::Options damped = jacobi_newton_options(20000);
  damped.damping = 0.3;
  damped.newton_substeps = 2;
  compare<Channel, 2>(base, guesses, params, damped, 1e-12);
}

TEST(BatchSweepHostPath, NonlinearJacobiOnAHardeningSpring) {
  const pardel::Problem base = problem_of(hardening_spring_model, 1, 30, {0.2}, {-0.4});
  const auto guesses = wiggly_guesses(base, 5, 0.3, 0.5, 11);
  pardel::Options o = jacobi_newton_options(50000);
  o.method = pardel::Method::jacobi;
  compare<Spring, 1>(base, guesses, std::vector<std::vector<double>>(5), o, 1e-12);
}

TEST(BatchSweepHostPath, DoubleSwingMidpointWithATolerance) {
  const pardel::Problem base = problem_of(double_swing_model, 0.8, 20, {0.3, -0.2}, {-0.1, 0.4});
  const auto guesses = wiggly_guesses(base, 4, 0.2, 0.2, 3);
  std::vector<std::vector<double>> params = {{9.81}, {1.0}, {4.0}, {0.5}};
  pardel::Options o = jacobi_newton_options(40000);
  o.tol = 1e-9;
  compare<Swing, 2>(base, guesses, params, o, 1e-12);
}

TEST(BatchSweepHostPath, OrderTwoInSpaceUsesThePivotedSolve) {
  const pardel::Problem base = problem_of(min_accel3_model, 2, 16, {0, 0, 0, 1, 0, 0}, {1, 1, -1, 0, 1, 0});
  const auto guesses = wiggly_guesses(base, 3, 0.3, 0.4, 5);
  compare<Accel, 6>(base, guesses, std::vector<std::vector<double>>(3), jacobi_newton_options(6), 1e-12);
}

TEST(BatchSweepHostPath, OnTheWallIsNonFinite) {
  const pardel::Problem base = problem_of(barrier_channel_model, 1, 12, {0, 0}, {0.5, 0});
  auto guesses = wiggly_guesses(base, 2, 0.0, 0.0, 1);
  guesses[1].q[6 * 2] = 1.0;  // a node on the wall x = 1: the barrier's derivatives divide by 1 - x^2 = 0
  std::vector<std::vector<double>> params = {{0, 0, 0.1}, {0, 0, 0.1}};
  compare<Channel, 2>(base, guesses, params, jacobi_newton_options(3000), 1e-12);
}

}  // namespace

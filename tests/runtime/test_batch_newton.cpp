/**
 * @file test_batch_newton.cpp
 * The host path of the device Newton solver (runtime/cuda/batch_newton.hpp: one problem's Newton
 * iteration, run here by host_newton in plain loops over the batch's interleaved arrays, as the
 * device runs it with one thread per problem). Its block LDL^T direction against a dense
 * solve of the same shifted block-tridiagonal matrix (and its s^T H s); its converged answers against solve() with
 * method newton (the CPU's trust-region Newton) on test models no bundled example resembles: a
 * channel with a logarithmic barrier (dimension 2, params), a hardening spring (dimension 1), a
 * double swing whose Hessian is indefinite at the guess (the shifted steps), minimum acceleration in
 * space (order 2, dimension 6); and the stops: non-finite guesses, max_iterations.
 */
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <vector>

#include "barrier_channel.hpp"
#include "batch_test_support.hpp"
#include "batch_newton.hpp"
#include "double_swing.hpp"
#include "hardening_spring.hpp"
#include "min_accel3.hpp"
#include "pardel/pardel.hpp"

namespace {

using batch_test::problem_of;
using batch_test::termination_of;
using batch_test::wiggly_guesses;

namespace bn = pardel::batch_newton;
namespace bs = pardel::batch_sweep;

#define PARDEL_FULL_OF(Type, symbol)                                                                          \
  struct Type {                                                                                               \
    static void full(double h, double t0, double t1, const double* q0, const double* q1, const double* p,     \
                     double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {              \
      symbol(h, t0, t1, q0, q1, p, Ld, D1, D2, D11, D12, D22);                                                \
    }                                                                                                         \
  };
PARDEL_FULL_OF(Channel, barrier_channel_trapezoid_full)
PARDEL_FULL_OF(Spring, hardening_spring_trapezoid_full)
PARDEL_FULL_OF(Swing, double_swing_midpoint_full)
PARDEL_FULL_OF(Accel, min_accel3_trapezoid_alpha_1_full)
#undef PARDEL_FULL_OF

/** direction() against Eigen's dense solve of (H + shift M) s = -r, H block tridiagonal with the
 *  blocks A_k on its diagonal and B_k above it (B_k^T below), M the identity or tridiag(-1, 2, -1)
 *  per component, for symmetric positive definite matrices of several block sizes, shifts and N;
 *  and false for an indefinite one. */
template <int D>
void check_direction(int N, double shift, int difference, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> work(static_cast<std::size_t>(bn::values_per_problem<D>(N)), 0.0);
  const bn::Arrays<D> a = bn::arrays<D>(work.data(), N, 1, 0);
  const int n = (N - 1) * D;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd r(n);
  for (int k = 1; k <= N - 1; ++k) {
    Eigen::MatrixXd G(D, D);
    for (int i = 0; i < D * D; ++i) G(i / D, i % D) = u(rng);
    const Eigen::MatrixXd Ak = G * G.transpose() + (2.5 * D) * Eigen::MatrixXd::Identity(D, D);
    for (int i = 0; i < D; ++i)
      for (int j = 0; j < D; ++j) a.A[0][static_cast<long>(k) * D * D + i * D + j] = Ak(i, j);
    H.block((k - 1) * D, (k - 1) * D, D, D) = Ak;
    for (int i = 0; i < D; ++i) r((k - 1) * D + i) = a.r[0][static_cast<long>(k) * D + i] = u(rng);
    if (k <= N - 2) {
      Eigen::MatrixXd Bk(D, D);
      for (int i = 0; i < D * D; ++i) Bk(i / D, i % D) = a.B[0][static_cast<long>(k) * D * D + i] = 0.8 * u(rng);
      H.block((k - 1) * D, k * D, D, D) = Bk;
      H.block(k * D, (k - 1) * D, D, D) = Bk.transpose();
    }
  }
  ASSERT_TRUE(bn::direction<D>(N, shift, difference, a));
  Eigen::MatrixXd M = Eigen::MatrixXd::Identity(n, n);
  if (difference) {
    M *= 2;
    for (int i = 0; i + D < n; ++i) M(i, i + D) = M(i + D, i) = -1;
  }
  const Eigen::VectorXd s = -(H + shift * M).ldlt().solve(r);
  for (int i = 0; i < n; ++i) EXPECT_NEAR(a.step[D + i], s(i), 1e-12 * (1 + s.cwiseAbs().maxCoeff()));
  const double sHs = s.dot(H * s);
  EXPECT_NEAR(bn::curvature<D>(N, a, 0), sHs, 1e-12 * (1 + std::fabs(sHs)));
  for (int i = 0; i < D; ++i) {
    EXPECT_EQ(a.step[i], 0.0);
    EXPECT_EQ(a.step[static_cast<long>(N) * D + i], 0.0);
  }
  // Made indefinite in its last block: the factorization says so.
  for (int i = 0; i < D; ++i) a.A[0][static_cast<long>(N - 1) * D * D + i * D + i] = -40.0 * D;
  EXPECT_FALSE(bn::direction<D>(N, shift, difference, a));
}

TEST(BatchNewtonHostPath, DirectionIsTheDenseSolve) {
  for (int difference = 0; difference < 2; ++difference) {
    check_direction<1>(2, 0, difference, 1);
    check_direction<1>(40, 0.5, difference, 2);
    check_direction<2>(3, 0.2, difference, 3);
    check_direction<2>(31, 0, difference, 4);
    check_direction<3>(17, 1e-3, difference, 5);
    check_direction<6>(12, 0.7, difference, 6);
  }
}

bs::Settings settings_of(const pardel::Options& options) {
  bs::Settings set;
  set.tol = options.tol;
  set.rtol = options.rtol;
  set.max_iterations = options.max_iterations;
  set.divergence_factor = options.divergence_factor;
  set.difference = options.newton_shift == pardel::NewtonShift::difference;
  return set;
}

pardel::Options newton_options() {
  pardel::Options o;
  o.method = pardel::Method::newton;
  o.threads = 1;
  o.error_estimate = false;
  o.iterative_refinement = pardel::Refinement::off;
  return o;
}

/** Each problem (a guess holding its boundary values, params) by host_newton and by solve(); both
 *  must converge to the same trajectory (to `tolerance` relative to its size), and solve()'s
 *  answer must be a minimum. Returns host_newton's states. */
template <class Kernel, int D>
std::vector<bn::State<D>> compare(const pardel::Problem& base, const std::vector<pardel::Trajectory>& guesses,
                                  const std::vector<std::vector<double>>& params, const pardel::Options& options,
                                  double tolerance) {
  const int B = static_cast<int>(guesses.size()), N = base.N;
  const int np = base.model->nparams;
  const std::size_t per = static_cast<std::size_t>(N + 1) * D;
  batch_test::FlatBatch f = batch_test::flatten(base, guesses, params);
  std::vector<double>& q = f.q;
  std::vector<double> work(static_cast<std::size_t>(B * bn::values_per_problem<D>(N)));
  std::vector<bn::State<D>> state(B);
  bn::host_newton<Kernel, D>(B, N, q.data(), f.t.data(), f.h.data(), f.p.data(), np, settings_of(options), 3,
                             work.data(), state.data());
  for (int b = 0; b < B; ++b) {
    const pardel::Problem problem = batch_test::entry_of(base, guesses[b], params[b]);
    pardel::Trajectory tr = guesses[b];
    const pardel::Summary s = pardel::solve(problem, options, tr);
    SCOPED_TRACE("problem " + std::to_string(b) + ": " + s.message);
    EXPECT_EQ(termination_of(state[b].s.status), pardel::Termination::converged);
    EXPECT_EQ(s.termination, pardel::Termination::converged);
    EXPECT_EQ(s.point.kind, pardel::PointKind::minimum);
    EXPECT_LE(state[b].s.residual, state[b].s.target);
    double diff = 0, size = 0;
    for (std::size_t i = 0; i < per; ++i) {
      diff = std::max(diff, std::fabs(q[b * per + i] - tr.q[i]));
      size = std::max(size, std::fabs(tr.q[i]));
    }
    EXPECT_LE(diff, tolerance * (1 + size)) << "actions " << s.action << " (cpu) " << state[b].action;
    // Its own answer, assessed on the CPU, is a minimum too.
    pardel::Trajectory mine = tr;
    std::copy(q.begin() + b * per, q.begin() + (b + 1) * per, mine.q.begin());
    EXPECT_EQ(pardel::assess_point(problem, mine, 1).kind, pardel::PointKind::minimum);
  }
  return state;
}

TEST(BatchNewtonHostPath, ChannelConvergesToTheCpuAnswerInFewIterations) {
  const pardel::Problem base = problem_of(barrier_channel_model, 1.5, 60, {-0.3, 0}, {0.4, 1});
  const auto guesses = wiggly_guesses(base, 6, 0.2, 0.3, 7);
  std::vector<std::vector<double>> params;
  for (int b = 0; b < 6; ++b) params.push_back({0.3 - 0.1 * b, -0.5 + 0.2 * b, 0.02 * b});
  const auto states = compare<Channel, 2>(base, guesses, params, newton_options(), 1e-9);
  for (const auto& s : states) EXPECT_LE(s.s.iterations, 12);  // Newton's quadratic convergence
}

TEST(BatchNewtonHostPath, HardeningSpringWithATolerance) {
  const pardel::Problem base = problem_of(hardening_spring_model, 1, 80, {0.2}, {-0.4});
  const auto guesses = wiggly_guesses(base, 5, 0.3, 0.5, 11);
  pardel::Options o = newton_options();
  o.tol = 1e-11;
  compare<Spring, 1>(base, guesses, std::vector<std::vector<double>>(5), o, 1e-9);
}

TEST(BatchNewtonHostPath, DoubleSwingFromAGuessWhereTheHessianIsIndefinite) {
  const pardel::Problem base = problem_of(double_swing_model, 1.6, 40, {0.3, -0.2}, {-0.1, 0.4});
  auto guesses = wiggly_guesses(base, 3, 0.2, 0.2, 3);
  std::vector<std::vector<double>> params = {{9.81}, {9.81}, {12.0}};
  // The straight guess's Hessian has a negative eigenvalue (long arcs of a swing): Newton's first
  // direction needs a shift.
  const auto inertia = pardel::assess_point(
      [&] {
        pardel::Problem p = base;
        p.params = params[0];
        p.q0.assign(guesses[0].q.begin(), guesses[0].q.begin() + 2);
        p.qN.assign(guesses[0].q.end() - 2, guesses[0].q.end());
        return p;
      }(),
      guesses[0], 1);
  ASSERT_GT(inertia.negative, 0);
  const auto states = compare<Swing, 2>(base, guesses, params, newton_options(), 1e-8);
  EXPECT_GT(states[0].shifted, 0);
}

TEST(BatchNewtonHostPath, OrderTwoInSpace) {
  const pardel::Problem base = problem_of(min_accel3_model, 2, 30, {0, 0, 0, 1, 0, 0}, {1, 1, -1, 0, 1, 0});
  const auto guesses = wiggly_guesses(base, 3, 0.3, 0.4, 5);
  compare<Accel, 6>(base, guesses, std::vector<std::vector<double>>(3), newton_options(), 1e-8);
}

TEST(BatchNewtonHostPath, StopsAsTheCpuSolverDoes) {
  const pardel::Problem base = problem_of(barrier_channel_model, 1, 12, {0, 0}, {0.5, 0});
  auto guesses = wiggly_guesses(base, 2, 0.0, 0.3, 1);
  guesses[1].q[6 * 2] = 1.0;  // a node on the wall x = 1: the barrier's derivatives divide by 1 - x^2 = 0
  const int N = base.N;
  const std::size_t per = static_cast<std::size_t>(N + 1) * 2;
  std::vector<double> q(2 * per), p = {0, 0, 0.1, 0, 0, 0.1}, t(N + 1), h(N, 1.0 / N);
  for (int b = 0; b < 2; ++b) std::copy(guesses[b].q.begin(), guesses[b].q.end(), q.begin() + b * per);
  for (int k = 0; k <= N; ++k) t[k] = static_cast<double>(k) / N;
  std::vector<double> work(static_cast<std::size_t>(2 * bn::values_per_problem<2>(N)));
  pardel::Options o = newton_options();
  o.max_iterations = 1;
  std::vector<bn::State<2>> state(2);
  bn::host_newton<Channel, 2>(2, N, q.data(), t.data(), h.data(), p.data(), 3, settings_of(o), 1, work.data(),
                              state.data());
  EXPECT_EQ(state[0].s.status, bs::max_iterations);  // one step is not enough from a wiggly guess
  EXPECT_EQ(state[0].s.iterations, 1);
  EXPECT_EQ(state[1].s.status, bs::non_finite);  // the guess itself: non-finite residual at node 6
  EXPECT_EQ(state[1].s.node, 6);
  EXPECT_EQ(state[1].s.iterations, 0);
  for (std::size_t i = 0; i < per; ++i) EXPECT_EQ(q[per + i], guesses[1].q[i]);  // returned as given
  // And the CPU solver says the same of both.
  for (int b = 0; b < 2; ++b) {
    pardel::Problem problem = base;
    problem.params = {0, 0, 0.1};
    pardel::Trajectory tr = guesses[b];
    const pardel::Summary s = pardel::solve(problem, o, tr);
    EXPECT_EQ(termination_of(state[b].s.status), s.termination) << s.message;
  }
}

}  // namespace

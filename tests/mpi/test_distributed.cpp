/**
 * @file test_distributed.cpp
 * The domain-decomposed solve against the one-process pardel::solve on the same problem in the
 * same run (run by mpirun on 2 and 3 ranks, the clock tests also on 4): the seed's Jacobi methods
 * bit for bit (a fixed number of iterations and to convergence, with damping, knots, clocks and
 * threads inside the ranks; under fixed_total_time also when the clock moves nodes across ranks),
 * Newton and hybrid to the tolerance, the levels of refinement and of the automatic method's grid
 * sequencing (those of one process, from the first that fits the ranks), the halo exchange and the
 * rank-order sum, the point assessment (kind, inertia and eigenvalue estimates; a two-fold lowest mode
 * judged by the third eigenvalue), refusals (a
 * degenerate Lagrangian with the one-process message), a NaN or an
 * interruption on one rank ending every rank (its iterate not assessed, as in one process), the
 * automatic method's second attempt (one process only, and the summary over ranks says so), the
 * error estimate (from the solve's own grid levels over ranks, as in one process), and checkpoints: the state of an interrupted solve
 * over ranks is the one-process state, and resumed over ranks or in one process (so is a
 * one-process state over ranks) it ends as the uninterrupted solve. The
 * acceptance test (LargeGrid.*: pendulum at N = 10^6) runs separately under a ctest label.
 */
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "mpi/decomposition.hpp"
#include "pardel/distributed.hpp"
#include "pardel/mpi_session.hpp"
#include "pardel/pardel.hpp"

namespace {

int world_rank() { return pardel::mpi::world_rank(); }
int world_size() { return pardel::mpi::world_size(); }
bool mpi_active() { return pardel::mpi::Session::current() && pardel::mpi::Session::current()->active(); }

pardel::Problem bundled_problem(const char* model, const char* disc, double T, int N, std::vector<double> q0,
                                std::vector<double> qN) {
  pardel::Problem p;
  p.model = pardel::find_model(model);
  EXPECT_NE(p.model, nullptr) << model;
  p.discretization = pardel::find_discretization(*p.model, disc);
  EXPECT_NE(p.discretization, nullptr) << disc;
  p.T = T;
  p.N = N;
  p.q0 = std::move(q0);
  p.qN = std::move(qN);
  return p;
}

pardel::Problem fuel_nav(int N) { return bundled_problem("fuel_nav", "trapezoid", 30, N, {0, 0}, {6, 5}); }

/** The interp_fuel scene: order 2, two knots, c = 50. */
pardel::Problem interp_fuel(int N) {
  pardel::Problem p = bundled_problem("interp_fuel", "trapezoid(alpha=1)", 60, N, {0, 0, 0, 0}, {3, 5, 0, 0});
  p.params = {50};
  p.knots = {{20, {1, 3}}, {40, {5, 2}}};
  return p;
}

struct Both {
  pardel::Summary one, dist;
  pardel::Trajectory one_traj, dist_traj;
};

/** The one-process solve and the distributed solve from the same guess. */
Both solve_both(const pardel::Problem& problem, const pardel::Options& options, const pardel::Trajectory& guess) {
  Both b;
  b.one_traj = guess;
  b.one = pardel::solve(problem, options, b.one_traj);
  b.dist_traj = guess;
  b.dist = pardel::mpi::solve_distributed(problem, options, b.dist_traj);
  return b;
}

/** Same termination, iterations, residuals, actions, history and (on rank 0) iterate, bit for bit. */
void expect_bit_for_bit(const Both& b) {
  EXPECT_EQ(b.one.termination, b.dist.termination) << b.one.message << " | " << b.dist.message;
  EXPECT_EQ(b.one.iterations, b.dist.iterations);
  EXPECT_EQ(b.one.residual, b.dist.residual);
  EXPECT_EQ(b.one.residual_floor, b.dist.residual_floor);
  EXPECT_EQ(b.one.action, b.dist.action);
  EXPECT_EQ(b.one.final_time, b.dist.final_time);
  ASSERT_EQ(b.one.history.size(), b.dist.history.size());
  for (std::size_t i = 0; i < b.one.history.size(); ++i) {
    EXPECT_EQ(b.one.history[i].iteration, b.dist.history[i].iteration) << "record " << i;
    EXPECT_EQ(b.one.history[i].residual, b.dist.history[i].residual) << "record " << i;
    EXPECT_EQ(b.one.history[i].action, b.dist.history[i].action) << "record " << i;
  }
  EXPECT_EQ(b.dist_traj.N, b.one_traj.N);
  if (world_rank() == 0) {
    ASSERT_EQ(b.one_traj.q.size(), b.dist_traj.q.size());
    EXPECT_EQ(0, std::memcmp(b.one_traj.q.data(), b.dist_traj.q.data(), b.one_traj.q.size() * sizeof(double)))
        << "the gathered iterate differs from the one-process iterate";
    EXPECT_EQ(b.one_traj.t, b.dist_traj.t);
  } else {
    EXPECT_TRUE(b.dist_traj.q.empty());
  }
}

double max_abs_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(a[i] - b[i]));
  return m;
}

/** The grids of the levels a solve ran, in order (the N of its history records). */
std::vector<int> level_Ns(const pardel::Summary& s) {
  std::vector<int> levels;
  for (const pardel::IterationRecord& rec : s.history)
    if (levels.empty() || levels.back() != rec.N) levels.push_back(rec.N);
  return levels;
}

// ---- the decomposition itself

TEST(Decomposition, OwnedRangesCoverTheNodesContiguously) {
  for (int N : {2, 7, 10, 1000}) {
    for (int P : {1, 2, 3, 4, 7}) {
      int next = 0;
      for (int r = 0; r < P; ++r) {
        const pardel::mpi::NodeRange range = pardel::mpi::owned_nodes(N, P, r);
        EXPECT_EQ(range.first, next) << "N " << N << " P " << P << " r " << r;
        EXPECT_LE(range.last - range.first, (N + 1) / P + 1);
        next = range.last + 1;
      }
      EXPECT_EQ(next, N + 1);
    }
  }
}

TEST(Decomposition, HaloExchangeBringsTheNeighboursNodes) {
  if (!mpi_active()) GTEST_SKIP() << "needs mpirun";
  const int N = 20, d = 3, P = world_size(), rank = world_rank();
  const auto layout = pardel::mpi::detail::make_layout(N, P, rank);
  std::vector<double> local(static_cast<std::size_t>(layout.hi - layout.lo + 1) * d, -1.0);
  auto value = [](int g, int a) { return 100.0 * g + a; };
  for (int g = layout.first; g <= layout.last; ++g)
    for (int a = 0; a < d; ++a) local[static_cast<std::size_t>(layout.local(g)) * d + a] = value(g, a);
  pardel::mpi::detail::exchange_halos(layout, local.data(), d, MPI_COMM_WORLD);
  for (int g = layout.lo; g <= layout.hi; ++g)
    for (int a = 0; a < d; ++a)
      EXPECT_EQ(local[static_cast<std::size_t>(layout.local(g)) * d + a], value(g, a)) << "node " << g;
  EXPECT_EQ(layout.lo, rank > 0 ? layout.first - 1 : 0);
  EXPECT_EQ(layout.hi, rank + 1 < P ? layout.last + 1 : N);
}

TEST(Decomposition, OrderedSumRoundsLikeOneSequentialLoop) {
  if (!mpi_active()) GTEST_SKIP() << "needs mpirun";
  // Values whose sum depends on the order of additions.
  const int N = 30, P = world_size(), rank = world_rank();
  std::vector<double> all(static_cast<std::size_t>(N));
  for (int k = 0; k < N; ++k) all[static_cast<std::size_t>(k)] = (k % 3 == 0 ? 1e16 : 1.0) * (k % 2 ? -1 : 1) + 0.1 * k;
  double sequential = 0;
  for (double v : all) sequential += v;
  const auto layout = pardel::mpi::detail::make_layout(N - 1, P, rank);  // 30 nodes: one value per node
  const double distributed = pardel::mpi::detail::ordered_sum(
      layout, all.data() + layout.first, layout.last - layout.first + 1, MPI_COMM_WORLD);
  EXPECT_EQ(distributed, sequential);
}

// ---- the seed's Jacobi methods: bit for bit

TEST(JacobiNewton, FixedIterationsBitForBit) {
  const auto problem = fuel_nav(100);
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.max_iterations = 300;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  EXPECT_EQ(b.one.termination, pardel::Termination::max_iterations);
  expect_bit_for_bit(b);
}

TEST(JacobiNewton, ThreadedRanksBitForBit) {
  // Large enough that every rank's loops run on 2 OpenMP threads (above kParallelMin nodes per rank).
  const auto problem = fuel_nav(3000);
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.max_iterations = 40;
  options.threads = 2;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  EXPECT_EQ(b.one.termination, pardel::Termination::max_iterations);
  expect_bit_for_bit(b);
}

TEST(JacobiNewton, ToConvergenceBitForBit) {
  auto problem = bundled_problem("harmonic", "trapezoid", 2.0, 40, {0.3}, {-0.7});
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.threads = 2;
  options.tol = 1e-12;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  EXPECT_EQ(b.one.termination, pardel::Termination::converged) << b.one.message;
  expect_bit_for_bit(b);
}

TEST(JacobiNewton, DampedSubstepsWithKnotsBitForBit) {
  const auto problem = interp_fuel(240);
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.damping = 0.2;
  options.newton_substeps = 2;
  options.max_iterations = 200;
  options.history_every = 7;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  expect_bit_for_bit(b);
}

TEST(Jacobi, NonlinearBlocksToConvergenceBitForBit) {
  auto problem = bundled_problem("pendulum", "midpoint", 1.0, 50, {0.0}, {1.0});
  pardel::Options options;
  options.method = pardel::Method::jacobi;
  options.damping = 0.1;
  options.tol = 1e-9;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  EXPECT_EQ(b.one.termination, pardel::Termination::converged) << b.one.message;
  expect_bit_for_bit(b);
}

// ---- node times from the clock: a prefix sum over the ranks, bit for bit

TEST(Clock, FreeFinalTimeBitForBit) {
  auto problem = bundled_problem("zermelo_tv", "trapezoid", 1.0, 50, {1, 6}, {6, 2});
  problem.clock = pardel::ClockMode::free_final_time;
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.clock_update_every = 10;
  options.max_iterations = 300;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  EXPECT_NE(b.one.final_time, problem.t0 + problem.T);  // the clock moved the final time
  expect_bit_for_bit(b);
}

TEST(Clock, FixedTotalTimeBitForBit) {
  auto problem = bundled_problem("zermelo_tv", "trapezoid", 1.0, 60, {1, 6}, {6, 2});
  problem.clock = pardel::ClockMode::fixed_total_time;
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.clock_update_every = 7;
  options.max_iterations = 200;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  if (world_rank() == 0) {
    bool uneven = false;  // the clock placed the nodes unevenly
    for (int k = 1; k < problem.N && !uneven; ++k)
      uneven = std::fabs(b.one_traj.t[k] - (problem.t0 + problem.T * k / problem.N)) > 1e-6;
    EXPECT_TRUE(uneven);
  }
  expect_bit_for_bit(b);
}

TEST(Clock, FixedTotalTimeRefinementBitForBit) {
  // Levels 15, 30, 60 (4 nodes per rank on 4 ranks at the first): each level starts from the
  // previous level's solution and node times, gathered on every rank, as in one process.
  auto problem = bundled_problem("zermelo_tv", "trapezoid", 1.0, 60, {1, 6}, {6, 2});
  problem.clock = pardel::ClockMode::fixed_total_time;
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.refine_start_N = 15;
  options.refine_factor = 2;
  options.clock_update_every = 7;
  options.max_iterations = 2000;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  if (world_rank() == 0)
    std::printf("%ld iterations, %s, residual %.3g\n", b.one.iterations, pardel::to_string(b.one.termination),
                b.one.residual);
  EXPECT_EQ(level_Ns(b.one), (std::vector<int>{15, 30, 60}));
  EXPECT_EQ(level_Ns(b.dist), level_Ns(b.one));
  expect_bit_for_bit(b);
}

/** `problem` from its linear guess with node times crowded at the start (t_k = t0 + T (k/N)^3):
 *  the clock's first placement (a solve of no iteration) moves interior nodes past the old nodes
 *  that their rank holds, halos included, so their values come from other ranks' nodes; then a
 *  solve of `iterations` iterations. Both bit for bit. */
void expect_retimed_across_ranks(pardel::Problem problem, pardel::Options options, long iterations) {
  problem.clock = pardel::ClockMode::fixed_total_time;
  pardel::Trajectory guess = pardel::linear_guess(problem);
  const int N = problem.N;
  for (int k = 0; k < N; ++k) {
    const double s = static_cast<double>(k) / N;
    guess.t[static_cast<std::size_t>(k)] = problem.t0 + problem.T * s * s * s;
  }
  options.max_iterations = 0;
  const Both placed = solve_both(problem, options, guess);
  expect_bit_for_bit(placed);
  if (world_rank() == 0) {
    int crossed = 0;  // interior nodes whose new time lies outside the old times of their rank's nodes
    for (int r = 0; r < world_size(); ++r) {
      const pardel::mpi::NodeRange range = pardel::mpi::owned_nodes(N, world_size(), r);
      const double lo = guess.t[static_cast<std::size_t>(std::max(range.first - 1, 0))];
      const double hi = guess.t[static_cast<std::size_t>(std::min(range.last + 1, N))];
      for (int k = std::max(range.first, 1); k <= std::min(range.last, N - 1); ++k) {
        const double t = placed.one_traj.t[static_cast<std::size_t>(k)];
        crossed += t < lo || t > hi;
      }
    }
    EXPECT_GT(crossed, 0);
    std::printf("%s: %d of %d interior nodes placed outside their rank's old times\n", problem.model->name, crossed,
                N - 1);
  }
  options.max_iterations = iterations;
  const Both b = solve_both(problem, options, guess);
  if (world_rank() == 0)
    std::printf("%s: %ld iterations, %s, residual %.3g\n", problem.model->name, b.one.iterations,
                pardel::to_string(b.one.termination), b.one.residual);
  expect_bit_for_bit(b);
}

TEST(Clock, FixedTotalTimeNodesMovedAcrossRanksBitForBit) {
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.clock_update_every = 5;
  options.threads = 1;
  // Order 1 (slopes from central differences) on 24 nodes: 6 per rank on 4 ranks.
  expect_retimed_across_ranks(bundled_problem("zermelo_tv", "trapezoid", 1.0, 23, {1, 6}, {6, 2}), options, 150);
  // Order 2 (the stored velocities as slopes): the spacecraft_sundman scene's model and boundary values.
  expect_retimed_across_ranks(bundled_problem("spacecraft", "trapezoid(alpha=1)", 0.13761699442396208, 31,
                                              {-0.00028185006780313756, 0, 0, -0.10294753382194759},
                                              {0.0020378554360866549, 0.0015651707922623602, -0.019359200263837129,
                                               0.025205716648293883}),
                              options, 40);
}

// ---- Newton: to the tolerance

void expect_newton_agrees(const Both& b, double tol, double trajectory_tol) {
  ASSERT_EQ(b.one.termination, pardel::Termination::converged) << b.one.message;
  ASSERT_EQ(b.dist.termination, pardel::Termination::converged) << b.dist.message;
  EXPECT_LE(b.dist.residual, tol);
  EXPECT_NEAR(b.dist.action, b.one.action, 1e-12 * (1 + std::fabs(b.one.action)));
  // The iteration counts may differ: over hundreds of Levenberg-Marquardt steps, differences of
  // the linear solves at the rounding level change the shift's path (not where it ends).
  if (world_rank() == 0) {
    ASSERT_EQ(b.one_traj.q.size(), b.dist_traj.q.size());
    const double dq = max_abs_difference(b.one_traj.q, b.dist_traj.q);
    EXPECT_LE(dq, trajectory_tol);
    std::printf("iterations %ld and %ld, max |q difference| %.3g, action difference %.3g\n", b.one.iterations,
                b.dist.iterations, dq, std::fabs(b.one.action - b.dist.action));
  }
}

TEST(Newton, FuelNavAgreesToTheTolerance) {
  const auto problem = fuel_nav(200);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.tol = 1e-10;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  expect_newton_agrees(b, options.tol, 1e-7);  // measured on 2 and 3 ranks: 5e-14
}

TEST(Newton, DifferenceShiftWithKnotsAgreesToTheTolerance) {
  const auto problem = interp_fuel(240);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.newton_shift = pardel::NewtonShift::difference;
  options.tol = 2e-8;  // above 10x the residual's round-off level here (1.35e-9, Summary::residual_floor)
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  expect_newton_agrees(b, options.tol, 1e-6);  // measured on 2 and 3 ranks: 4e-13, 1e-11
}

TEST(Hybrid, FuelNavAgreesToTheTolerance) {
  const auto problem = fuel_nav(80);
  pardel::Options options;
  options.method = pardel::Method::hybrid;
  options.tol = 1e-10;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  expect_newton_agrees(b, options.tol, 1e-7);
}

// ---- levels: coarse-to-fine refinement and the automatic method's grid sequencing, as in one process

TEST(Levels, JacobiNewtonRefinementWithKnotsBitForBit) {
  // Every level's solution is gathered on every rank and resampled there as in one process, so the
  // seed's method stays bit for bit across levels: 30, 60, 120 (grids that hold the knots).
  const auto problem = interp_fuel(120);
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.refine_start_N = 30;
  options.refine_factor = 2;
  options.max_iterations = 4000;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  EXPECT_EQ(level_Ns(b.one), (std::vector<int>{30, 60, 120}));
  EXPECT_EQ(level_Ns(b.dist), level_Ns(b.one));
  expect_bit_for_bit(b);
}

TEST(Levels, NewtonRefinementAgreesToTheTolerance) {
  // Levels 50, 100, 200: the last starts from the extrapolation of the two before it.
  const auto problem = fuel_nav(200);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.refine_start_N = 50;
  options.refine_factor = 2;
  options.tol = 1e-10;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  EXPECT_EQ(level_Ns(b.one), (std::vector<int>{50, 100, 200}));
  EXPECT_EQ(level_Ns(b.dist), level_Ns(b.one));
  expect_newton_agrees(b, options.tol, 1e-7);  // as Newton.FuelNavAgreesToTheTolerance on one grid
}

TEST(Levels, AutomaticSequencesGridsAsInOneProcess) {
  // N = 12800: the automatic method's levels 800, 3200, 12800 (the finest from the extrapolation).
  // The pendulum of LargeGrid.*, well conditioned: both iterates lie within |H^{-1}|_inf |r|_inf of
  // the discrete solution, |H^{-1}|_inf <= T^2 / (8 h) / (1 - g T^2 / pi^2) for this Hessian.
  const int N = 12800;
  const double T = 0.5, g = 9.81, h = T / N;
  const auto problem = bundled_problem("pendulum", "midpoint", T, N, {0.0}, {1.0});
  pardel::Options options;  // Method::automatic, rtol
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  ASSERT_EQ(b.one.termination, pardel::Termination::converged) << b.one.message;
  ASSERT_EQ(b.dist.termination, pardel::Termination::converged) << b.dist.message;
  EXPECT_EQ(b.dist.method, pardel::Method::newton);
  EXPECT_EQ(level_Ns(b.one), (std::vector<int>{800, 3200, 12800}));
  EXPECT_EQ(level_Ns(b.dist), level_Ns(b.one));
  EXPECT_EQ(b.dist.N, N);
  EXPECT_EQ(b.dist_traj.N, N);
  const double q_tol = T * T / (8 * h) / (1 - g * T * T / (M_PI * M_PI)) * (b.one.residual + b.dist.residual);
  // The action is stationary: the iterates' difference moves it at second order, the rounding of
  // two sums of N terms by at most N eps sum |Ld_k| (here sum |Ld_k| ~ |action|).
  EXPECT_NEAR(b.dist.action, b.one.action, N * std::numeric_limits<double>::epsilon() * (1 + std::fabs(b.one.action)));
  if (world_rank() == 0) {
    ASSERT_EQ(b.one_traj.q.size(), b.dist_traj.q.size());
    const double dq = max_abs_difference(b.one_traj.q, b.dist_traj.q);
    EXPECT_LE(dq, q_tol);
    std::printf("automatic, N = %d: iterations %ld and %ld, max |q difference| %.3g (bound %.3g)\n", N,
                b.one.iterations, b.dist.iterations, dq, q_tol);
  }
}

// The error estimate over ranks is made from the automatic method's own grid levels (N = 12800:
// its levels 800 and 3200 lie on the final grid's nodes), where the result is held, and shared:
// the same estimate as one process (its solution agrees to the tolerance), confirmed by the third
// level, within a factor 3 of the true error against the exact x = A cos t + B sin t, and equal
// on every rank.
TEST(ErrorEstimate, OverRanksFromTheSolvesOwnLevels) {
  const int N = 12800;
  const double T = 2.5, q0 = 0.3, qN = -0.7;
  const auto problem = bundled_problem("harmonic", "trapezoid", T, N, {q0}, {qN});
  pardel::Options options;  // Method::automatic
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  ASSERT_EQ(b.one.termination, pardel::Termination::converged) << b.one.message;
  ASSERT_EQ(b.dist.termination, pardel::Termination::converged) << b.dist.message;
  ASSERT_TRUE(std::isfinite(b.dist.error_estimate)) << b.dist.error_note;
  EXPECT_EQ(b.dist.error_coarse_N, b.one.error_coarse_N);
  EXPECT_EQ(b.dist.error_coarse_N, N / 4);
  EXPECT_TRUE(b.dist.error_reliable) << b.dist.error_note;
  // The estimate is max_k |x_N - x_{N/4}| / (4^2 - 1): it moves by at most (|dx_N| + |dx_{N/4}|) / 15,
  // where each level's two solutions differ by at most |H^-1|_inf (r_one + r_dist) (their last
  // residuals there), |H^-1|_inf <= T^2 / (8 h) / (1 - T^2 / pi^2) for this Hessian (as in
  // Levels.AutomaticSequencesGridsAsInOneProcess).
  auto last_residual = [](const pardel::Summary& s, int n) {
    double r = std::numeric_limits<double>::quiet_NaN();
    for (const pardel::IterationRecord& rec : s.history)
      if (rec.N == n) r = rec.residual;
    return r;
  };
  auto apart = [&](int n) {
    return T * T / (8 * (T / n)) / (1 - T * T / (M_PI * M_PI)) * (last_residual(b.one, n) + last_residual(b.dist, n));
  };
  const double moved = (apart(N) + apart(N / 4)) / 15;
  ASSERT_TRUE(std::isfinite(moved));
  EXPECT_NEAR(b.dist.error_estimate, b.one.error_estimate, moved);
  ASSERT_EQ(b.dist.error_by_coordinate.size(), 1u);
  EXPECT_EQ(b.dist.error_by_coordinate[0], b.dist.error_estimate);
  EXPECT_NE(b.dist.error_note.find("N = 3200 is a grid level the solve had solved"), std::string::npos)
      << b.dist.error_note;
  EXPECT_NE(b.dist.error_note.find("N = 800 is another grid level the solve had solved"), std::string::npos)
      << b.dist.error_note;
  EXPECT_GT(b.dist.error_seconds, 0);
  double mine[2] = {b.dist.error_estimate, -b.dist.error_estimate}, all[2] = {0, 0};
  MPI_Allreduce(mine, all, 2, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  EXPECT_EQ(all[0], -all[1]) << "the estimate differs between ranks";
  if (world_rank() == 0) {
    const double B = (qN - q0 * std::cos(T)) / std::sin(T);
    double truth = 0;
    for (int k = 0; k <= N; ++k) {
      const double t = T * k / N;
      truth = std::max(truth, std::fabs(b.dist_traj.node(k)[0] - (q0 * std::cos(t) + B * std::sin(t))));
    }
    EXPECT_GT(b.dist.error_estimate, truth / 3);
    EXPECT_LT(b.dist.error_estimate, truth * 3);
    std::printf("estimate over ranks %.4g, one process %.4g (bound on their difference %.3g), true max node error "
                "%.4g\n",
                b.dist.error_estimate, b.one.error_estimate, moved, truth);
  }
}

// Without a grid level of its own on the final grid's nodes, a solve over ranks is not estimated
// (the coarse solve that one process makes is not made there), and every rank says why.
TEST(ErrorEstimate, OverRanksWithoutNestedLevelsSaysWhy) {
  const auto problem = bundled_problem("harmonic", "trapezoid", 2.0, 40, {0.3}, {-0.7});
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  ASSERT_EQ(b.dist.termination, pardel::Termination::converged) << b.dist.message;
  EXPECT_TRUE(std::isfinite(b.one.error_estimate)) << b.one.error_note;
  EXPECT_TRUE(std::isnan(b.dist.error_estimate));
  EXPECT_EQ(b.dist.error_coarse_N, 0);
  EXPECT_NE(b.dist.error_note.find("not estimated: no grid level of the solve lies on every r-th node of N = 40, and "
                                   "over MPI ranks the estimate uses the solve's own grid levels only"),
            std::string::npos)
      << b.dist.error_note;
}

TEST(Levels, StartAtTheFirstLevelThatFitsTheRanks) {
  // refine_start_N = 4: one process runs 4, 8, 16, ...; over 2 or 3 ranks a level needs N + 1 >= 3
  // ranks nodes, so the distributed solve starts at 8 and then runs the same levels.
  const auto problem = fuel_nav(100);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.refine_start_N = 4;
  options.refine_factor = 2;
  options.tol = 1e-10;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  const std::vector<int> one = level_Ns(b.one);
  EXPECT_EQ(one, (std::vector<int>{4, 8, 16, 32, 64, 100}));
  if (world_size() > 1 && world_size() <= 3)
    EXPECT_EQ(level_Ns(b.dist), std::vector<int>(one.begin() + 1, one.end()));
  expect_newton_agrees(b, options.tol, 1e-7);
}

TEST(Levels, StoppedOnACoarseLevelSaysSo) {
  const auto problem = fuel_nav(200);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.refine_start_N = 50;
  options.max_iterations = 3;
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  EXPECT_EQ(b.dist.termination, pardel::Termination::max_iterations) << b.dist.message;
  EXPECT_EQ(b.dist.message, b.one.message);
  EXPECT_NE(b.dist.message.find("(stopped at the refinement level N = 50; the trajectory returned is that level's "
                                "iterate interpolated to the requested N = 200)"),
            std::string::npos)
      << b.dist.message;
  EXPECT_EQ(b.dist.N, 200);
  if (world_rank() == 0) {
    EXPECT_EQ(b.dist_traj.N, 200);
    EXPECT_EQ(b.dist_traj.q.size(), b.one_traj.q.size());
  }
}

// ---- refusals and failures

// ---- the point assessment over ranks: the kind, inertia and (at a minimum) the eigenvalue
// estimates of the one-process assessment

void expect_same_point(const Both& b) {
  EXPECT_EQ(b.dist.point.kind, b.one.point.kind) << b.one.point.note << " | " << b.dist.point.note;
  EXPECT_EQ(b.dist.point.positive, b.one.point.positive);
  EXPECT_EQ(b.dist.point.negative, b.one.point.negative);
  EXPECT_EQ(b.dist.point.zero, b.one.point.zero);
  if (b.one.point.kind != pardel::PointKind::minimum) return;
  // The same Lanczos iteration from the same start with another solver and other sums: Ritz values
  // that settled within 1e-4 and 3e-3 of their limits agree to about that.
  EXPECT_TRUE(b.one.point.lambda_settled && b.dist.point.lambda_settled) << b.one.point.note << " | " << b.dist.point.note;
  EXPECT_NEAR(b.dist.point.lambda_min, b.one.point.lambda_min, 1e-3 * b.one.point.lambda_min);
  EXPECT_NEAR(b.dist.point.lambda_next, b.one.point.lambda_next, 1e-2 * b.one.point.lambda_next);
  EXPECT_NEAR(b.dist.point.lambda_max, b.one.point.lambda_max, 1e-12 * b.one.point.lambda_max);
  EXPECT_EQ(b.dist.point.nearly_degenerate, b.one.point.nearly_degenerate);
  EXPECT_GT(b.dist.point.lambda_min, 0);
}

TEST(Point, MinimumSaddleAndKnotsAsInOneProcess) {
  // A minimum (fuel_nav solved), a problem with knots (fixed components) solved, and iterates
  // that are no solution (the harmonic oscillator past its conjugate point after a few sweeps;
  // the fuel example at the straight line): not assessed, on ranks as in one process.
  pardel::Options newton;
  newton.method = pardel::Method::newton;
  newton.threads = 1;
  const auto fuel = fuel_nav(200);
  const Both solved = solve_both(fuel, newton, pardel::linear_guess(fuel));
  ASSERT_TRUE(solved.one.converged()) << solved.one.message;
  EXPECT_EQ(solved.dist.point.kind, pardel::PointKind::minimum) << solved.dist.point.note;
  expect_same_point(solved);
  pardel::Options sweeps;
  sweeps.method = pardel::Method::jacobi_newton;
  sweeps.threads = 1;
  sweeps.max_iterations = 5;
  const auto harmonic = bundled_problem("harmonic", "trapezoid", 4.0, 40, {1.0}, {1.0});
  const Both past = solve_both(harmonic, sweeps, pardel::linear_guess(harmonic));
  EXPECT_EQ(past.dist.point.kind, pardel::PointKind::unknown) << past.dist.point.note;
  EXPECT_EQ(past.dist.point.note, past.one.point.note);
  expect_same_point(past);
  sweeps.max_iterations = 1;
  const Both line = solve_both(fuel, sweeps, pardel::linear_guess(fuel));
  EXPECT_EQ(line.dist.point.kind, pardel::PointKind::unknown) << line.dist.point.note;
  expect_same_point(line);
  const auto knots = interp_fuel(240);
  pardel::Options to_tol = newton;
  to_tol.tol = 2e-8;  // as Newton.DifferenceShiftWithKnotsAgreesToTheTolerance (the default rtol takes 391 iterations)
  const Both with_knots = solve_both(knots, to_tol, pardel::linear_guess(knots));
  ASSERT_TRUE(with_knots.one.converged()) << with_knots.one.message;
  expect_same_point(with_knots);
}

TEST(Point, GalerkinInteriorValuesCountOverRanksAsInOneProcess) {
  // x'' = -x over T = 40 on 12 intervals under galerkin_gauss(s=4): the node Hessian (the condensed
  // action's) is positive definite and each interval's interior block has one negative eigenvalue,
  // so the whole action has index 12 (tests/python/test_galerkin_inertia.py checks such counts
  // against NumPy); over ranks each counts its own intervals and the counts are summed.
  pardel::Options newton;
  newton.method = pardel::Method::newton;
  newton.threads = 1;
  const auto oscillator = bundled_problem("harmonic", "galerkin_gauss(s=4)", 40.0, 12, {1.0}, {0.5});
  const Both b = solve_both(oscillator, newton, pardel::linear_guess(oscillator));
  ASSERT_TRUE(b.one.converged()) << b.one.message;
  ASSERT_TRUE(b.dist.converged()) << b.dist.message;
  EXPECT_EQ(b.one.point.kind, pardel::PointKind::saddle) << b.one.point.note;
  EXPECT_EQ(b.one.point.negative, 12) << b.one.point.note;  // NumPy: 12 (and 35 positive)
  EXPECT_EQ(b.one.point.positive, 35) << b.one.point.note;
  expect_same_point(b);
}

// ---- models written here (one or two coordinates): the sweep, gradient and action kernels from a
// full kernel

using FullKernel = void (*)(double, double, double, const double*, const double*, const double*, double*, double*,
                            double*, double*, double*, double*);
template <FullKernel full>
void sweep_of(double h, double t0, double t1, const double* q0, const double* q1, const double* p, double* D1,
              double* D2, double* D11, double* D22) {
  double Ld, D12[4];
  full(h, t0, t1, q0, q1, p, &Ld, D1, D2, D11, D12, D22);
}
template <FullKernel full>
void grad_of(double h, double t0, double t1, const double* q0, const double* q1, const double* p, double* Ld,
             double* D1, double* D2) {
  double a[4], b[4], c[4];
  full(h, t0, t1, q0, q1, p, Ld, D1, D2, a, b, c);
}
template <FullKernel full>
double action_of(double h, double t0, double t1, const double* q0, const double* q1, const double* p) {
  double Ld, D1[2], D2[2];
  grad_of<full>(h, t0, t1, q0, q1, p, &Ld, D1, D2);
  return Ld;
}

// The isotropic oscillator in the plane, L = (|q'|^2 - |q|^2) / 2 (trapezoid): its Hessian is two
// copies of tridiag(-1/h, 2/h - h, -1/h), every eigenvalue twice.
void plane_full(double h, double, double, const double* q0, const double* q1, const double*, double* Ld, double* D1,
                double* D2, double* D11, double* D12, double* D22) {
  *Ld = 0;
  for (int a = 0; a < 2; ++a) {
    const double dq = q1[a] - q0[a];
    *Ld += dq * dq / (2 * h) - h * (q0[a] * q0[a] + q1[a] * q1[a]) / 4;
    D1[a] = -dq / h - h * q0[a] / 2;
    D2[a] = dq / h - h * q1[a] / 2;
  }
  for (int k = 0; k < 4; ++k) {
    const double on = k == 0 || k == 3 ? 1.0 : 0.0;
    D11[k] = D22[k] = on * (1 / h - h / 2);
    D12[k] = -on / h;
  }
}
const char* const plane_coords[] = {"a", "b"};
const pardel_discretization plane_discs[] = {
    {"trapezoid", 2, plane_full, sweep_of<plane_full>, grad_of<plane_full>, action_of<plane_full>}};
const pardel_model plane_model = {PARDEL_KERNEL_ABI_VERSION, "isotropic_plane", "", 1, 2, 2, plane_coords, 0, nullptr,
                                  nullptr, 0, nullptr, 1, plane_discs, nullptr, PARDEL_COST_ACTION};

TEST(Point, ATwoFoldLowestModeOverRanksAsInOneProcess) {
  // The plane oscillator near its conjugate time pi: the two smallest eigenvalues are equal
  // ((4/h) sin^2(pi / 2N) - h, twice), the third 5.9e4 times larger at T = pi - 1e-4, so the
  // minimum is nearly degenerate with a two-fold lowest mode; at T = 1 the third is 4.3 times
  // larger and it is not. The third eigenvalue's Lanczos run over ranks decides as in one process.
  pardel::Options newton;
  newton.method = pardel::Method::newton;
  newton.threads = 1;
  for (const double T : {3.14159265358979323846 - 1e-4, 1.0}) {
    const int N = 256;
    pardel::Problem problem;
    problem.model = &plane_model;
    problem.discretization = &plane_model.discretizations[0];
    problem.T = T;
    problem.N = N;
    problem.q0 = {1.0, 0.3};
    problem.qN = {-0.9, -0.2};
    const Both b = solve_both(problem, newton, pardel::linear_guess(problem));
    ASSERT_TRUE(b.one.converged()) << b.one.message;
    ASSERT_TRUE(b.dist.converged()) << b.dist.message;
    expect_same_point(b);
    const double h = T / N, s1 = std::sin(3.14159265358979323846 / (2 * N));
    const double lambda1 = 4 / h * s1 * s1 - h;
    const bool soft = T > 3;
    for (const pardel::Summary* s : {&b.one, &b.dist}) {
      EXPECT_EQ(s->point.kind, pardel::PointKind::minimum) << s->point.note;
      EXPECT_NEAR(s->point.lambda_min, lambda1, 1e-4 * lambda1) << s->point.note;
      EXPECT_NEAR(s->point.lambda_next, lambda1, 3e-3 * lambda1) << s->point.note;
      EXPECT_EQ(s->point.nearly_degenerate, soft) << s->point.note;
      if (soft)
        EXPECT_EQ(s->point.note.find("a nearly degenerate minimum whose lowest mode is two-fold"), 0u) << s->point.note;
      else
        EXPECT_NE(s->point.note.find("(as a two-fold lowest mode makes them), and the third"), std::string::npos) << s->point.note;
    }
  }
}

// ---- checkpoints: an interrupted solve's state over ranks, resumed over ranks or in one process

/** Sends rank 0's `v` to every rank. */
template <class T>
void broadcast_vector(std::vector<T>& v, MPI_Datatype type) {
  long n = static_cast<long>(v.size());
  MPI_Bcast(&n, 1, MPI_LONG, 0, MPI_COMM_WORLD);
  v.resize(static_cast<std::size_t>(n));
  MPI_Bcast(v.data(), static_cast<int>(n), type, 0, MPI_COMM_WORLD);
}

void broadcast_trajectory(pardel::Trajectory& tr) {
  int sizes[2] = {tr.N, tr.dim};
  MPI_Bcast(sizes, 2, MPI_INT, 0, MPI_COMM_WORLD);
  tr.N = sizes[0];
  tr.dim = sizes[1];
  broadcast_vector(tr.t, MPI_DOUBLE);
  broadcast_vector(tr.q, MPI_DOUBLE);
}

/** Rank 0's state on every rank (a distributed solve captures it on rank 0; the CLI's ranks each
 *  read checkpoint.json). */
void broadcast_state(pardel::SolverState& st) {
  long counters[9] = {st.valid, static_cast<long>(st.method), st.level, st.N, st.iteration, st.level_iteration,
                      st.since_clock_update, st.next_record, st.best_iteration};
  MPI_Bcast(counters, 9, MPI_LONG, 0, MPI_COMM_WORLD);
  st.valid = counters[0] != 0;
  st.method = static_cast<pardel::Method>(counters[1]);
  st.level = static_cast<int>(counters[2]);
  st.N = static_cast<int>(counters[3]);
  st.iteration = counters[4];
  st.level_iteration = counters[5];
  st.since_clock_update = counters[6];
  st.next_record = counters[7];
  st.best_iteration = counters[8];
  double values[8] = {st.have_initial_residual ? 1.0 : 0.0, st.initial_residual, st.last_good_residual,
                      st.best_residual, st.level_initial_residual, st.level_checkpoint_residual, st.seconds, 0};
  MPI_Bcast(values, 8, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  st.have_initial_residual = values[0] != 0;
  st.initial_residual = values[1];
  st.last_good_residual = values[2];
  st.best_residual = values[3];
  st.level_initial_residual = values[4];
  st.level_checkpoint_residual = values[5];
  st.seconds = values[6];
  broadcast_trajectory(st.trajectory);
  broadcast_trajectory(st.previous_level);
  broadcast_vector(st.method_state, MPI_DOUBLE);
  std::vector<double> history;
  for (const pardel::IterationRecord& r : st.history)
    history.insert(history.end(), {static_cast<double>(r.iteration), static_cast<double>(r.N), r.residual, r.action,
                                   r.seconds});
  broadcast_vector(history, MPI_DOUBLE);
  st.history.clear();
  for (std::size_t i = 0; i + 4 < history.size(); i += 5)
    st.history.push_back({static_cast<long>(history[i]), static_cast<int>(history[i + 1]), history[i + 2],
                          history[i + 3], history[i + 4]});
}

/** Interrupts the solve by on_iteration at the record of iteration `at`: a distributed solve by
 *  the last rank alone (`by_last_rank`), a solve in one process on every rank. */
pardel::Options interrupted_at(pardel::Options options, long at, bool by_last_rank = false) {
  const bool asks = !by_last_rank || world_rank() + 1 == world_size();
  options.on_iteration = [asks, at](const pardel::IterationRecord& record) { return !(asks && record.iteration >= at); };
  return options;
}

/** Both states hold the same iterate, level and counters (the one-process layout), bit for bit
 *  (`tolerance` 0) or the iterates and the method's values to `tolerance`; the wall times aside. */
void expect_same_state(const pardel::SolverState& a, const pardel::SolverState& b, double tolerance) {
  EXPECT_TRUE(a.valid);
  EXPECT_TRUE(b.valid);
  EXPECT_EQ(a.method, b.method);
  EXPECT_EQ(a.level, b.level);
  EXPECT_EQ(a.N, b.N);
  EXPECT_EQ(a.iteration, b.iteration);
  EXPECT_EQ(a.level_iteration, b.level_iteration);
  EXPECT_EQ(a.since_clock_update, b.since_clock_update);
  EXPECT_EQ(a.next_record, b.next_record);
  EXPECT_EQ(a.best_iteration, b.best_iteration);
  EXPECT_EQ(a.have_initial_residual, b.have_initial_residual);
  EXPECT_EQ(a.history.size(), b.history.size());
  EXPECT_EQ(a.trajectory.N, b.trajectory.N);
  ASSERT_EQ(a.trajectory.q.size(), b.trajectory.q.size());
  ASSERT_EQ(a.trajectory.t.size(), b.trajectory.t.size());
  ASSERT_EQ(a.method_state.size(), b.method_state.size());
  EXPECT_EQ(a.previous_level.N, b.previous_level.N);
  ASSERT_EQ(a.previous_level.q.size(), b.previous_level.q.size());
  if (tolerance == 0) {
    EXPECT_EQ(a.initial_residual, b.initial_residual);
    EXPECT_EQ(a.best_residual, b.best_residual);
    EXPECT_EQ(a.level_initial_residual, b.level_initial_residual);
    EXPECT_EQ(a.trajectory.q, b.trajectory.q);
    EXPECT_EQ(a.trajectory.t, b.trajectory.t);
    EXPECT_EQ(a.method_state, b.method_state);
    EXPECT_EQ(a.previous_level.q, b.previous_level.q);
  } else {
    EXPECT_LE(max_abs_difference(a.trajectory.q, b.trajectory.q), tolerance);
    EXPECT_LE(max_abs_difference(a.previous_level.q, b.previous_level.q), tolerance);
  }
}

/** A distributed solve interrupted at iteration `at`, its state (from rank 0) on every rank. */
pardel::SolverState interrupted_over_ranks(const pardel::Problem& problem, const pardel::Options& options,
                                           const pardel::Trajectory& guess, long at) {
  pardel::Trajectory tr = guess;
  pardel::Summary s = pardel::mpi::solve_distributed(problem, interrupted_at(options, at, true), tr);
  EXPECT_EQ(s.termination, pardel::Termination::interrupted) << s.message;
  EXPECT_EQ(s.iterations, at);
  if (world_size() > 1 && world_rank() != 0) EXPECT_FALSE(s.state.valid);  // rank 0 holds the state
  broadcast_state(s.state);
  return s.state;
}

/** The uninterrupted distributed solve and the one resumed from `state`: the same iterations,
 *  history and answer, bit for bit. */
void expect_resumed_bit_for_bit(const pardel::Problem& problem, pardel::Options options,
                                const pardel::Trajectory& guess, const pardel::SolverState& state) {
  Both b;
  b.one_traj = guess;  // the uninterrupted distributed solve, in the place of "one"
  b.one = pardel::mpi::solve_distributed(problem, options, b.one_traj);
  options.resume_from = &state;
  b.dist = pardel::mpi::solve_distributed(problem, options, b.dist_traj);  // from no guess, as pardel solve --resume
  expect_bit_for_bit(b);
  EXPECT_EQ(b.dist.message, b.one.message);
  if (world_rank() == 0)
    std::printf("resumed at iteration %ld (N = %d): %ld iterations, %s\n", state.iteration, state.N,
                b.dist.iterations, pardel::to_string(b.dist.termination));
}

TEST(Resume, NewtonInterruptedOverRanksResumesBitForBit) {
  // Levels 50, 100, 200 (Newton's extrapolation needs the previous level's solution from the
  // state): interrupted on the first level, on the second and on the last.
  const auto problem = fuel_nav(200);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.refine_start_N = 50;
  options.refine_factor = 2;
  options.tol = 1e-10;
  options.threads = 1;
  const auto guess = pardel::linear_guess(problem);
  pardel::Trajectory tr = guess;
  const pardel::Summary plain = pardel::mpi::solve_distributed(problem, options, tr);
  ASSERT_EQ(level_Ns(plain), (std::vector<int>{50, 100, 200}));
  std::vector<long> at;  // the second iteration of each level
  for (std::size_t i = 1; i < plain.history.size(); ++i)
    if (plain.history[i].N != plain.history[i - 1].N || i == 1) at.push_back(plain.history[i].iteration + 1);
  ASSERT_EQ(at.size(), 3u);
  for (long k : at) {
    const pardel::SolverState state = interrupted_over_ranks(problem, options, guess, k);
    EXPECT_EQ(state.previous_level.N, state.level > 0 ? level_Ns(plain)[static_cast<std::size_t>(state.level) - 1] : 0);
    expect_resumed_bit_for_bit(problem, options, guess, state);
  }
}

TEST(Resume, HybridInterruptedOverRanksResumesBitForBit) {
  const auto problem = fuel_nav(80);
  pardel::Options options;
  options.method = pardel::Method::hybrid;
  options.tol = 1e-10;
  options.threads = 1;
  // In the sweeps (phase 0 of the state) from the linear guess; in Newton's steps (phase 1) from
  // a perturbed solution, which switches after a few sweeps.
  const auto guess = pardel::linear_guess(problem);
  const pardel::SolverState sweeping = interrupted_over_ranks(problem, options, guess, 5);
  ASSERT_FALSE(sweeping.method_state.empty());
  EXPECT_EQ(sweeping.method_state[0], 0.0);
  expect_resumed_bit_for_bit(problem, options, guess, sweeping);
  pardel::Trajectory near = guess;
  pardel::Options newton = options;
  newton.method = pardel::Method::newton;
  ASSERT_TRUE(pardel::solve(problem, newton, near).converged());
  for (int k = 1; k < problem.N; ++k)
    near.q[static_cast<std::size_t>(2 * k)] += 0.3 * std::sin(M_PI * k / problem.N);
  pardel::Trajectory tr = near;
  const pardel::Summary plain = pardel::mpi::solve_distributed(problem, options, tr);
  ASSERT_TRUE(plain.converged()) << plain.message;
  const pardel::SolverState stepping = interrupted_over_ranks(problem, options, near, plain.iterations - 1);
  ASSERT_FALSE(stepping.method_state.empty());
  EXPECT_EQ(stepping.method_state[0], 1.0);
  expect_resumed_bit_for_bit(problem, options, near, stepping);
}

TEST(Resume, JacobiNewtonStateOverRanksIsTheOneProcessStateBitForBit) {
  // The seed's method is bit for bit over ranks: the state captured over ranks is the one-process
  // state, and either one resumed over ranks or in one process ends as the uninterrupted solves.
  const auto problem = interp_fuel(240);
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.max_iterations = 300;
  options.history_every = 7;
  options.threads = 1;
  const auto guess = pardel::linear_guess(problem);
  const pardel::SolverState over_ranks = interrupted_over_ranks(problem, options, guess, 140);
  pardel::Trajectory tr = guess;
  const pardel::Summary one = pardel::solve(problem, interrupted_at(options, 140), tr);
  ASSERT_EQ(one.termination, pardel::Termination::interrupted) << one.message;
  expect_same_state(one.state, over_ranks, 0);
  expect_resumed_bit_for_bit(problem, options, guess, one.state);
  // The state of the ranks resumed in one process: the uninterrupted one-process solve.
  pardel::Trajectory plain_traj = guess, resumed_traj;
  const pardel::Summary plain = pardel::solve(problem, options, plain_traj);
  options.resume_from = &over_ranks;
  const pardel::Summary resumed = pardel::solve(problem, options, resumed_traj);
  EXPECT_EQ(resumed.termination, plain.termination) << resumed.message;
  EXPECT_EQ(resumed.iterations, plain.iterations);
  EXPECT_EQ(resumed.residual, plain.residual);
  EXPECT_EQ(resumed.action, plain.action);
  EXPECT_EQ(resumed.history.size(), plain.history.size());
  EXPECT_EQ(resumed_traj.q, plain_traj.q);
}

TEST(Clock, ResumedOverRanksBitForBit) {
  // Under fixed_total_time the state carries the node times; the level resumes at them.
  auto problem = bundled_problem("zermelo_tv", "trapezoid", 1.0, 60, {1, 6}, {6, 2});
  problem.clock = pardel::ClockMode::fixed_total_time;
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.clock_update_every = 7;
  options.max_iterations = 200;
  options.threads = 1;
  const auto guess = pardel::linear_guess(problem);
  const pardel::SolverState state = interrupted_over_ranks(problem, options, guess, 95);
  expect_resumed_bit_for_bit(problem, options, guess, state);
  pardel::Trajectory tr = guess;
  const pardel::Summary one = pardel::solve(problem, interrupted_at(options, 95), tr);
  expect_same_state(one.state, state, 0);
}

TEST(Resume, NewtonStatesMoveBetweenOneProcessAndRanks) {
  // The state of one process resumed over ranks, and the state of the ranks resumed in one
  // process, agree with the uninterrupted solves to the tolerance (as Levels.NewtonRefinement...).
  const auto problem = fuel_nav(200);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.refine_start_N = 50;
  options.refine_factor = 2;
  options.tol = 1e-10;
  options.threads = 1;
  const auto guess = pardel::linear_guess(problem);
  const long at = 9;
  pardel::Trajectory tr = guess;
  const pardel::Summary one = pardel::solve(problem, interrupted_at(options, at), tr);
  ASSERT_EQ(one.termination, pardel::Termination::interrupted) << one.message;
  const pardel::SolverState over_ranks = interrupted_over_ranks(problem, options, guess, at);
  expect_same_state(one.state, over_ranks, 1e-9);
  Both b;  // one process from the ranks' state, the ranks from one process's state
  pardel::Options resumed = options;
  resumed.resume_from = &over_ranks;
  b.one = pardel::solve(problem, resumed, b.one_traj);
  resumed.resume_from = &one.state;
  b.dist = pardel::mpi::solve_distributed(problem, resumed, b.dist_traj);
  expect_newton_agrees(b, options.tol, 1e-7);
  Both plain = solve_both(problem, options, guess);
  EXPECT_NEAR(b.one.action, plain.one.action, 1e-12 * (1 + std::fabs(plain.one.action)));
  if (world_rank() == 0) {
    EXPECT_LE(max_abs_difference(b.one_traj.q, plain.one_traj.q), 1e-7);
    EXPECT_LE(max_abs_difference(b.dist_traj.q, plain.dist_traj.q), 1e-7);
  }
}

TEST(Resume, WarmStartOverRanksAsInOneProcess) {
  // Jacobi-Newton's iterate continued by Newton (pardel solve --resume DIR --set solver.method=newton).
  const auto problem = fuel_nav(200);
  pardel::Options sweeps;
  sweeps.method = pardel::Method::jacobi_newton;
  sweeps.threads = 1;
  const pardel::SolverState state = interrupted_over_ranks(problem, sweeps, pardel::linear_guess(problem), 30);
  pardel::Options newton;
  newton.method = pardel::Method::newton;
  newton.tol = 1e-10;
  newton.threads = 1;
  newton.resume_from = &state;
  newton.warm_start = true;
  const Both b = solve_both(problem, newton, pardel::Trajectory{});
  expect_newton_agrees(b, newton.tol, 1e-7);
  EXPECT_GT(b.dist.iterations, 30);
  EXPECT_EQ(b.dist.history.front().iteration, b.one.history.front().iteration);
  EXPECT_NE(b.dist.message.find("(warm start from iteration 30 of jacobi-newton at N = 200)"), std::string::npos)
      << b.dist.message;
}

TEST(Resume, AStateThatDoesNotFitIsRefusedAsInOneProcess) {
  const auto problem = fuel_nav(100);
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.threads = 1;
  const pardel::SolverState state = interrupted_over_ranks(problem, options, pardel::linear_guess(problem), 10);
  options.resume_from = &state;
  // Another N; another method; a method state that does not fit.
  const Both wrong_N = solve_both(fuel_nav(120), options, pardel::Trajectory{});
  EXPECT_EQ(wrong_N.dist.termination, pardel::Termination::invalid_input);
  EXPECT_EQ(wrong_N.dist.message, wrong_N.one.message);
  EXPECT_NE(wrong_N.dist.message.find("resume: refinement level 0 with N = 100"), std::string::npos)
      << wrong_N.dist.message;
  pardel::SolverState newton_state = state;
  newton_state.method = pardel::Method::newton;
  options.method = pardel::Method::newton;
  options.resume_from = &newton_state;
  const Both misfit = solve_both(problem, options, pardel::Trajectory{});
  EXPECT_EQ(misfit.dist.termination, pardel::Termination::invalid_input);
  EXPECT_EQ(misfit.dist.message, misfit.one.message);
  EXPECT_NE(misfit.dist.message.find("values that do not fit"), std::string::npos) << misfit.dist.message;
}

// A Lagrangian without velocity, L = x^2 / 2 (trapezoid): D12 Ld = 0 on every interval.
void still_full(double h, double, double, const double* q0, const double* q1, const double*, double* Ld, double* D1,
                double* D2, double* D11, double* D12, double* D22) {
  *Ld = h * (q0[0] * q0[0] + q1[0] * q1[0]) / 4;
  D1[0] = h * q0[0] / 2;
  D2[0] = h * q1[0] / 2;
  D11[0] = D22[0] = h / 2;
  D12[0] = 0;
}
const char* const still_coords[] = {"x"};
const pardel_discretization still_discs[] = {
    {"trapezoid", 2, still_full, sweep_of<still_full>, grad_of<still_full>, action_of<still_full>}};
const pardel_model still_model = {PARDEL_KERNEL_ABI_VERSION, "no_velocity_1d", "", 1, 1, 1, still_coords, 0, nullptr,
                                  nullptr, 0, nullptr, 1, still_discs, nullptr, PARDEL_COST_ACTION};

/** A problem of a 1-D model written here, from x = 0 to x = 1 over [0, T]. */
pardel::Problem written_problem(const pardel_model& model, double T, int N) {
  pardel::Problem problem;
  problem.model = &model;
  problem.discretization = &model.discretizations[0];
  problem.T = T;
  problem.N = N;
  problem.q0 = {0};
  problem.qN = {1};
  return problem;
}

TEST(Refusal, DegenerateLagrangianAsInOneProcess) {
  const pardel::Problem problem = written_problem(still_model, 2, 83);
  for (pardel::Method method : {pardel::Method::jacobi_newton, pardel::Method::newton}) {
    pardel::Options options;
    options.method = method;
    options.threads = 1;
    const Both b = solve_both(problem, options, pardel::linear_guess(problem));
    EXPECT_EQ(b.dist.termination, pardel::Termination::invalid_input) << b.dist.message;
    EXPECT_EQ(b.dist.message, b.one.message);
    EXPECT_NE(b.dist.message.find("is degenerate"), std::string::npos) << b.dist.message;
    EXPECT_EQ(b.dist.iterations, 0);
  }
}

TEST(Refusal, UnsupportedCombinationsNameTheKey) {
  if (world_size() < 2) GTEST_SKIP() << "refusals apply to more than one rank";
  const auto problem = fuel_nav(100);
  // A state of a level too small for the ranks (refine_start_N = 4: N + 1 < 3 ranks).
  pardel::Options coarse;
  coarse.method = pardel::Method::jacobi_newton;
  coarse.refine_start_N = 4;
  coarse.refine_factor = 2;
  coarse.threads = 1;
  auto guess = pardel::linear_guess(problem);
  const pardel::Summary one = pardel::solve(problem, interrupted_at(coarse, 1), guess);
  ASSERT_EQ(one.state.N, 4);
  coarse.resume_from = &one.state;
  auto s = pardel::mpi::solve_distributed(problem, coarse, guess);
  EXPECT_EQ(s.termination, pardel::Termination::invalid_input);
  EXPECT_NE(s.message.find("resume: refinement level 0 with N = 4 is too small for"), std::string::npos) << s.message;
  auto small = fuel_nav(4);
  guess = pardel::linear_guess(small);
  s = pardel::mpi::solve_distributed(small, pardel::Options{}, guess);
  EXPECT_EQ(s.termination, pardel::Termination::invalid_input);
  EXPECT_NE(s.message.find("grid.N = 4"), std::string::npos) << s.message;
  // Newton on the DEL residual runs in one process only.
  pardel::Options stationary;
  stationary.method = pardel::Method::stationary_newton;
  guess = pardel::linear_guess(problem);
  s = pardel::mpi::solve_distributed(problem, stationary, guess);
  EXPECT_EQ(s.termination, pardel::Termination::invalid_input);
  EXPECT_NE(s.message.find("\"stationary-newton\" runs in one process only"), std::string::npos) << s.message;
}

// A harmonic oscillator whose kernels return NaN once x exceeds 1.05 in the second half of the
// time span (on the last rank): the iterates rise towards sin(2t)/sin(2), which peaks near 1.1.
void nan_full(double h, double t0, double, const double* q0, const double* q1, const double* p, double* Ld,
              double* D1, double* D2, double* D11, double* D12, double* D22) {
  const double w2 = p[0] * p[0], dx = q1[0] - q0[0];
  *Ld = dx * dx / (2 * h) - h * w2 * (q0[0] * q0[0] + q1[0] * q1[0]) / 4;
  D1[0] = -dx / h - h * w2 * q0[0] / 2;
  D2[0] = dx / h - h * w2 * q1[0] / 2;
  D11[0] = 1 / h - h * w2 / 2;
  D12[0] = -1 / h;
  D22[0] = 1 / h - h * w2 / 2;
  if (t0 > 0.5 && (q0[0] > 1.05 || q1[0] > 1.05)) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    *Ld = D1[0] = D2[0] = D11[0] = D12[0] = D22[0] = nan;
  }
}
const char* const nan_coords[] = {"x"};
const char* const nan_params[] = {"omega"};
const double nan_defaults[] = {2.0};
const pardel_discretization nan_discs[] = {
    {"trapezoid", 2, nan_full, sweep_of<nan_full>, grad_of<nan_full>, action_of<nan_full>}};
const pardel_model nan_model = {PARDEL_KERNEL_ABI_VERSION, "nan_harmonic", "", 1, 1, 1, nan_coords, 1, nan_params,
                                nan_defaults, 0, nullptr, 1, nan_discs, nullptr, PARDEL_COST_ACTION};

TEST(Failure, NaNOnOneRankEndsEveryRankAsNonFinite) {
  const pardel::Problem problem = written_problem(nan_model, 1, 30);
  for (pardel::Method method : {pardel::Method::jacobi_newton, pardel::Method::newton}) {
    pardel::Options options;
    options.method = method;
    options.threads = 1;
    const Both b = solve_both(problem, options, pardel::linear_guess(problem));
    if (method == pardel::Method::jacobi_newton) {
      EXPECT_EQ(b.dist.termination, pardel::Termination::non_finite) << b.dist.message;
      expect_bit_for_bit(b);
      EXPECT_EQ(b.one.message, b.dist.message);
      // The iterate of a failed solve is no DEL solution: neither solve assesses it, for the same reason.
      EXPECT_EQ(b.one.point.kind, pardel::PointKind::unknown);
      EXPECT_EQ(b.dist.point.kind, pardel::PointKind::unknown);
      EXPECT_EQ(b.dist.point.note, b.one.point.note);
      EXPECT_NE(b.dist.point.note.find("not assessed: the solve ended non_finite"), std::string::npos)
          << b.dist.point.note;
    } else {
      // Newton rejects the trial points with NaN and shortens its steps: it ends as one process does.
      EXPECT_EQ(b.dist.termination, b.one.termination) << b.one.message << " | " << b.dist.message;
    }
  }
}

TEST(Attempts, TheAutomaticMethodsSecondAttemptSaysWhyItIsNotMadeOverRanks) {
  // The harmonic oscillator from 0 to 1 over omega T = 4 > pi: past its conjugate point the action
  // is unbounded below and the only DEL solution is a saddle. The model declares no cost, so in
  // one process the automatic method's minimizing Newton diverges and Newton on the DEL residual
  // returns the saddle; over ranks that second attempt does not run, and the solve ends as the
  // minimizing Newton alone does, saying why.
  const auto problem = bundled_problem("harmonic", "trapezoid", 4.0, 200, {0.0}, {1.0});
  ASSERT_EQ(problem.model->cost_name, nullptr);
  pardel::Options automatic;
  automatic.threads = 1;
  const Both b = solve_both(problem, automatic, pardel::linear_guess(problem));
  ASSERT_TRUE(b.one.converged()) << b.one.message;
  EXPECT_EQ(b.one.method, pardel::Method::stationary_newton);
  EXPECT_EQ(b.one.point.kind, pardel::PointKind::saddle);
  if (world_size() < 2) return;
  pardel::Options newton = automatic;
  newton.method = pardel::Method::newton;
  auto minimizing = pardel::linear_guess(problem);
  const pardel::Summary first = pardel::solve(problem, newton, minimizing);
  EXPECT_EQ(first.termination, pardel::Termination::diverged) << first.message;
  EXPECT_EQ(b.dist.termination, first.termination) << b.dist.message;
  EXPECT_EQ(b.dist.method, pardel::Method::newton);
  EXPECT_NE(b.dist.message.find("the automatic method's second attempt for a model without a declared cost, was "
                                "not made: solver.method = \"stationary-newton\" runs in one process only"),
            std::string::npos)
      << b.dist.message;
  EXPECT_EQ(b.dist.point.kind, pardel::PointKind::unknown) << b.dist.point.note;
}

TEST(Failure, InterruptionOnOneRankStopsEveryRank) {
  const auto problem = fuel_nav(100);
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.threads = 1;
  const bool last_rank = world_rank() + 1 == world_size();
  options.on_iteration = [last_rank](const pardel::IterationRecord& record) {
    return !(last_rank && record.iteration >= 25);  // only the last rank asks to stop
  };
  auto trajectory = pardel::linear_guess(problem);
  const pardel::Summary s = pardel::mpi::solve_distributed(problem, options, trajectory);
  if (world_size() > 1) {
    EXPECT_EQ(s.termination, pardel::Termination::interrupted) << s.message;
    EXPECT_EQ(s.iterations, 25);
  }
}

// ---- the acceptance test: N = 10^6 on the ranks of this run against one process

TEST(LargeGrid, PendulumNewtonAtAMillionNodesMatchesOneProcess) {
  const int N = 1000000;
  const double T = 0.5, g = 9.81, h = T / N;  // T well below the first conjugate time pi / sqrt(g)
  auto problem = bundled_problem("pendulum", "midpoint", T, N, {0.0}, {1.0});
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.newton_shift = pardel::NewtonShift::difference;  // iteration count flat in N
  options.tol = 1e-8;  // the residual's cancellation floor at h = 5e-7 is near 1e-10
  options.threads = 1;
  const Both b = solve_both(problem, options, pardel::linear_guess(problem));
  ASSERT_EQ(b.one.termination, pardel::Termination::converged) << b.one.message;
  ASSERT_EQ(b.dist.termination, pardel::Termination::converged) << b.dist.message;
  EXPECT_NEAR(static_cast<double>(b.dist.iterations), static_cast<double>(b.one.iterations), 1.0);
  // Both iterates are within |H^{-1}|_inf |r|_inf of the discrete solution; for this Hessian,
  // (1/h) tridiag(-1, 2, -1) less at most h g on the diagonal, |H^{-1}|_inf <= T^2 / (8 h) / (1 - g T^2 / pi^2).
  const double inverse_norm = T * T / (8 * h) / (1 - g * T * T / (M_PI * M_PI));
  const double q_tol = inverse_norm * (b.one.residual + b.dist.residual);
  // The action is stationary, so the iterates' difference changes it at second order; what remains
  // is the rounding of two sums of N terms, at most N eps sum |Ld_k| (here sum |Ld_k| ~ |action|).
  const double action_tol = N * std::numeric_limits<double>::epsilon() * (1 + std::fabs(b.one.action));
  EXPECT_NEAR(b.dist.action, b.one.action, action_tol);
  if (world_rank() == 0) {
    ASSERT_EQ(b.one_traj.q.size(), b.dist_traj.q.size());
    const double dq = max_abs_difference(b.one_traj.q, b.dist_traj.q);
    EXPECT_LE(dq, q_tol);
    std::printf("N = %d: one process %ld iterations (residual %.3g, action %.17g, %.2f s); %d ranks %ld iterations "
                "(residual %.3g, action %.17g, %.2f s); max |q difference| %.3g (bound %.3g), action difference "
                "%.3g (bound %.3g)\n",
                N, b.one.iterations, b.one.residual, b.one.action, b.one.wall_seconds, world_size(), b.dist.iterations,
                b.dist.residual, b.dist.action, b.dist.wall_seconds, dq, q_tol, std::fabs(b.dist.action - b.one.action),
                action_tol);
  }
}

/** Prints the failed expectations of a rank other than 0. */
class FailurePrinter : public ::testing::EmptyTestEventListener {
 public:
  explicit FailurePrinter(int rank) : rank_(rank) {}
  void OnTestPartResult(const ::testing::TestPartResult& result) override {
    if (result.failed())
      std::fprintf(stderr, "rank %d: %s:%d: failure\n%s\n", rank_, result.file_name() ? result.file_name() : "?",
                   result.line_number(), result.summary());
  }

 private:
  int rank_;
};

}  // namespace

int main(int argc, char** argv) {
  const pardel::mpi::Session session(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  if (session.rank() != 0) {
    // One report: the other ranks print only their failures.
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
    listeners.Append(new FailurePrinter(session.rank()));
  }
  const int local = RUN_ALL_TESTS();
  int any = local;
  if (session.active()) MPI_Allreduce(&local, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return any;
}

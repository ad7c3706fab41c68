// solve_batch_cuda (pardel/cuda.hpp) against solve_batch on CPU cores with the same options, on
// batches with random boundary values, params and wiggly guesses of models compiled for the device
// (fuel navigation, Zermelo's vortices, a pendulum under nonlinear Jacobi, a damped 2-step
// Jacobi-Newton on the oscillator, Bratu's problem driven to overflow): the same status for every
// problem; iterates after a few sweeps equal to 1e-12; converged answers equal to 1e-8 with the
// same point found and iteration counts within 1% (the device contracts multiply-adds and has its
// own sin, cos, exp and sqrt, so the last bits differ and a test at the tolerance can pass a sweep
// earlier or later; a problem that fails after many sweeps fails the same way, not
// necessarily at the same sweep). A model added with pardel_add_model(... DEVICE) (a double swing of
// the runtime tests) is registered beside the bundled ones and solved the same way. What the device
// refuses, and that registration, are checked without a device; the comparisons skip, saying why,
// where there is none. Newton on the device (one problem per thread) against its host path
// (batch_newton.hpp's host_newton, the same functions in plain loops: the same statuses and
// answers) and against solve_batch's trust-region Newton (both converge, to minima).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "batch_newton.hpp"
#include "batch_test_support.hpp"
#include "fuel_nav.hpp"
#include "batch_entries.hpp"
#include "pardel/cuda.hpp"
#include "pardel/pardel.hpp"
#include "zermelo.hpp"

extern "C" const pardel_model pendulum_model, harmonic_model, bratu_model;
#ifdef PARDEL_HAVE_DEVICE_TEST_MODEL
#include "double_swing.hpp"
#endif

namespace {

using batch_test::problem_of;

pardel::Options options_of(pardel::Method method, long max_iterations) {
  pardel::Options o;
  o.method = method;
  o.max_iterations = max_iterations;
  o.error_estimate = false;
  o.iterative_refinement = pardel::Refinement::off;
  return o;
}

/** B problems: end points moved by up to `spread`, params scaled by up to `param_spread`, and a
 *  sine bump of up to `bump` on the straight line as the guess. */
std::vector<pardel::BatchProblem> random_batch(const pardel::Problem& base, int B, double spread, double param_spread,
                                               double bump, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const pardel_model& m = *base.model;
  std::vector<pardel::BatchProblem> out;
  for (int b = 0; b < B; ++b) {
    pardel::BatchProblem bp;
    bp.q0 = base.q0;
    bp.qN = base.qN;
    for (int i = 0; i < m.ncoords; ++i) {
      bp.q0[i] += spread * u(rng);
      bp.qN[i] += spread * u(rng);
    }
    for (int i = 0; i < m.nparams; ++i) bp.params.push_back(m.param_defaults[i] * (1 + param_spread * u(rng)));
    pardel::Problem p = base;
    p.q0 = bp.q0;
    p.qN = bp.qN;
    bp.guess = pardel::linear_guess(p);
    const double a = bump * u(rng), phase = 3 * u(rng);
    for (int k = 1; k < base.N; ++k)
      for (int i = 0; i < m.ncoords; ++i) bp.guess.q[k * m.dim + i] += a * std::sin(M_PI * k / base.N) * std::cos(phase + i);
    out.push_back(bp);
  }
  return out;
}

/** The number of problems that converged (on both). */
int compare(const pardel::Problem& base, const pardel::Options& options, const std::vector<pardel::BatchProblem>& batch,
            int blocks_per_problem = 0) {
  std::string why;
  if (!pardel::cuda_device_available(&why)) {
    std::printf("skipped: %s\n", why.c_str());
    return -1;
  }
  pardel::CudaSettings settings;
  settings.check_every = 7;  // not a divisor of the iteration counts: the device stops each problem at its own
  settings.blocks_per_problem = blocks_per_problem;
  const pardel::BatchSummary gpu = pardel::solve_batch_cuda(base, options, batch, settings);
  EXPECT_TRUE(gpu.refusal.empty()) << gpu.refusal;
  if (!gpu.refusal.empty()) return 0;
  pardel::Options cpu_options = options;
  cpu_options.threads = 0;
  const pardel::BatchSummary cpu = pardel::solve_batch(base, cpu_options, batch);
  EXPECT_EQ(gpu.entries.size(), cpu.entries.size());
  if (gpu.entries.size() != cpu.entries.size()) return 0;
  int converged = 0;
  for (std::size_t b = 0; b < batch.size(); ++b) {
    const pardel::Summary& g = gpu.entries[b].summary;
    const pardel::Summary& c = cpu.entries[b].summary;
    SCOPED_TRACE("problem " + std::to_string(b) + ": device: " + g.message + " | cpu: " + c.message);
    EXPECT_EQ(g.termination, c.termination);
    const bool few_sweeps = options.max_iterations < 20;
    if (few_sweeps)
      EXPECT_EQ(g.iterations, c.iterations);
    else if (c.converged())
      EXPECT_LE(std::labs(g.iterations - c.iterations), 2 + c.iterations / 100);
    const std::vector<double>& qg = gpu.entries[b].trajectory.q;
    const std::vector<double>& qc = cpu.entries[b].trajectory.q;
    EXPECT_EQ(qg.size(), qc.size());
    if (qg.size() != qc.size()) continue;
    double diff = 0, size = 0;
    for (std::size_t i = 0; i < qg.size(); ++i) {
      diff = std::max(diff, std::fabs(qg[i] - qc[i]));
      size = std::max(size, std::fabs(qc[i]));
    }
    if (few_sweeps || c.converged()) EXPECT_LE(diff, (few_sweeps ? 1e-12 : 1e-8) * (1 + size));
    if (c.converged()) {
      ++converged;
      EXPECT_EQ(g.point.kind, c.point.kind);
      EXPECT_LE(g.residual, g.tolerance);
    }
  }
  EXPECT_EQ(gpu.converged, cpu.converged);
  return converged;
}

/** Skips the test where there is no device. */
#define PARDEL_NEEDS_DEVICE()                                   \
  do {                                                          \
    std::string why;                                            \
    if (!pardel::cuda_device_available(&why)) GTEST_SKIP() << why; \
  } while (0)

TEST(DeviceBatchRefusals, MethodsKnotsAndModelsTheDeviceLacks) {
  const pardel::Problem base = problem_of(fuel_nav_model, 5, 20, {0, 0}, {1, 1});
  std::vector<pardel::BatchProblem> one(1);
  pardel::BatchSummary s = pardel::solve_batch_cuda(base, options_of(pardel::Method::hybrid, 10), one);
  EXPECT_NE(s.refusal.find("jacobi, jacobi-newton, newton and auto"), std::string::npos) << s.refusal;
  EXPECT_TRUE(s.entries.empty());
  pardel::Problem knotted = base;
  knotted.knots.push_back(pardel::Knot{});
  s = pardel::solve_batch_cuda(knotted, options_of(pardel::Method::jacobi_newton, 10), one);
  EXPECT_NE(s.refusal.find("knots"), std::string::npos) << s.refusal;
  EXPECT_TRUE(pardel::cuda_supports(fuel_nav_model, fuel_nav_model.discretizations[1]));
  // A model that is not in the device build: a copy under another name.
  pardel_model other = fuel_nav_model;
  other.name = "fuel_nav_copy";
  pardel_discretization disc = fuel_nav_model.discretizations[0];
  std::string why;
  EXPECT_FALSE(pardel::cuda_supports(other, disc, &why));
  EXPECT_NE(why.find("zermelo (trapezoid)"), std::string::npos) << why;
  // Models named like a bundled one that are other models (a .lag of the same name loaded at run
  // time): another source file, or the same in all but the Lagrangian (another sweep kernel).
  pardel_model elsewhere = fuel_nav_model;
  elsewhere.source = "/home/someone/fuel_nav.lag";
  EXPECT_FALSE(pardel::cuda_supports(elsewhere, disc, &why));
  EXPECT_NE(why.find("this one is generated from /home/someone/fuel_nav.lag; the device's model of that name is "
                     "another"),
            std::string::npos)
      << why;
  pardel_model other_wind = fuel_nav_model;
  pardel_discretization other_sweep = fuel_nav_model.discretizations[0];
  other_sweep.sweep = fuel_nav_model.discretizations[1].sweep;  // midpoint's kernel under trapezoid's name
  other_wind.discretizations = &other_sweep;
  other_wind.ndiscretizations = 1;
  EXPECT_FALSE(pardel::cuda_supports(other_wind, other_sweep));
  // A copy of the descriptors of the bundled model itself is that model.
  pardel_model same = fuel_nav_model;
  pardel_discretization same_disc = fuel_nav_model.discretizations[0];
  same.discretizations = &same_disc;
  same.ndiscretizations = 1;
  EXPECT_TRUE(pardel::cuda_supports(same, same_disc, &why)) << why;
  pardel::CudaSettings negative;
  negative.blocks_per_problem = -1;
  s = pardel::solve_batch_cuda(base, options_of(pardel::Method::jacobi_newton, 10), one, negative);
  EXPECT_NE(s.refusal.find("blocks_per_problem"), std::string::npos) << s.refusal;
}

TEST(DeviceBatch, FuelNavigationIteratesAfterNineSweeps) {
  PARDEL_NEEDS_DEVICE();
  const pardel::Problem base = problem_of(fuel_nav_model, 5, 40, {0, 0}, {1.5, 1});
  compare(base, options_of(pardel::Method::jacobi_newton, 9), random_batch(base, 40, 0.3, 0, 0.4, 1));
}

TEST(DeviceBatch, FuelNavigationToTheEnd) {
  PARDEL_NEEDS_DEVICE();
  const pardel::Problem base = problem_of(fuel_nav_model, 5, 20, {0, 0}, {1.5, 1});
  std::vector<pardel::BatchProblem> batch = random_batch(base, 64, 0.3, 0, 0.4, 2);
  // Two guesses on other grids: resampled to the problem's N, as solve() does.
  pardel::Problem coarse = base;
  coarse.N = 7;
  pardel::Problem fine = base;
  fine.N = 45;
  batch[5].guess = pardel::linear_guess(coarse);
  batch[6].guess = pardel::linear_guess(fine);
  EXPECT_GT(compare(base, options_of(pardel::Method::jacobi_newton, 20000), batch), 32);
}

TEST(DeviceBatch, ZermeloRoutesThroughTheVortices) {
  PARDEL_NEEDS_DEVICE();
  // The seed's routes at N = 80 from polylines between the vortices, each bend moved at random.
  // (At small N the Jacobi-Newton iterates of this wind are so sensitive that the last bits decide
  // between local solutions.)
  const pardel::Problem base = problem_of(zermelo_model, 1, 80, {0, 0}, {6, 2});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  std::vector<pardel::BatchProblem> batch(16);
  for (pardel::BatchProblem& bp : batch)
    bp.guess = pardel::polyline_guess(base, {{0, 0}, {1 + u(rng), 3.5 + u(rng)}, {4 + u(rng), 5.5 + u(rng)}, {6, 2}});
  EXPECT_GT(compare(base, options_of(pardel::Method::jacobi_newton, 60000), batch), 8);
}

TEST(DeviceBatch, PendulumUnderNonlinearJacobi) {
  PARDEL_NEEDS_DEVICE();
  const pardel::Problem base = problem_of(pendulum_model, 1.5, 30, {0.3}, {-0.8});
  EXPECT_GT(compare(base, options_of(pardel::Method::jacobi, 20000), random_batch(base, 33, 0.5, 0.3, 0.6, 4)), 16);
}

TEST(DeviceBatch, DampedTwoStepJacobiNewtonOnTheOscillator) {
  PARDEL_NEEDS_DEVICE();
  const pardel::Problem base = problem_of(harmonic_model, 2, 30, {1}, {-0.5});
  pardel::Options o = options_of(pardel::Method::jacobi_newton, 20000);
  o.damping = 0.4;
  o.newton_substeps = 2;
  o.tol = 1e-11;
  EXPECT_GT(compare(base, o, random_batch(base, 20, 0.5, 0.3, 0.8, 5)), 10);
}

TEST(DeviceBatch, BratuDrivenToOverflowStopsEachProblemAlone) {
  PARDEL_NEEDS_DEVICE();
  const pardel::Problem base = problem_of(bratu_model, 1, 24, {0}, {0});
  std::vector<pardel::BatchProblem> batch = random_batch(base, 12, 0.1, 0.5, 0.5, 6);
  for (int b = 0; b < 12; b += 3) batch[b].guess.q[12] = 800;  // exp(800) overflows
  compare(base, options_of(pardel::Method::jacobi_newton, 5000), batch);
}

TEST(DeviceBatch, ManyBlocksPerProblemAndThreadsThatTakeSeveralNodes) {
  PARDEL_NEEDS_DEVICE();
  // N = 1500: 12 blocks of 128 nodes. Five blocks per problem (each thread takes two or three
  // nodes, five blocks fold into a record before the last decides), then the automatic choice.
  const pardel::Problem base = problem_of(fuel_nav_model, 40, 1500, {0, 0}, {3, 2});
  const std::vector<pardel::BatchProblem> batch = random_batch(base, 6, 0.5, 0, 0.7, 7);
  compare(base, options_of(pardel::Method::jacobi_newton, 9), batch, 5);
  compare(base, options_of(pardel::Method::jacobi_newton, 9), batch, 0);
  compare(base, options_of(pardel::Method::jacobi_newton, 9), batch, 1);
  // Overflow at nodes in different blocks: the first one is named, whichever block folds first.
  const pardel::Problem bratu = problem_of(bratu_model, 1, 1500, {0}, {0});
  std::vector<pardel::BatchProblem> hot = random_batch(bratu, 4, 0.1, 0.5, 0.5, 8);
  hot[1].guess.q[1300] = 800;
  hot[1].guess.q[700] = 800;
  hot[2].guess.q[200] = 800;
  compare(bratu, options_of(pardel::Method::jacobi_newton, 400), hot, 5);
}

/** Newton's host path (batch_newton.hpp's host_newton) against the CPU's trust-region Newton: both
 *  converge on every problem, the host path's answers are minima; then, where there is a device,
 *  Newton on the device against the host path (the same functions: the same status, answers to
 *  1e-8, iteration counts within 2). Returns the problems whose host-path answer is the CPU's. */
template <class Kernel>
int compare_newton(const pardel::Problem& base, const std::vector<pardel::BatchProblem>& batch) {
  namespace bn = pardel::batch_newton;
  const pardel::Options options = options_of(pardel::Method::newton, 500);
  pardel::CudaSettings settings;
  settings.check_every = 3;
  const int B = static_cast<int>(batch.size()), N = base.N, np = base.model->nparams;
  constexpr int D = 2;
  const std::size_t per = static_cast<std::size_t>(N + 1) * D;
  std::vector<double> q(B * per), p(static_cast<std::size_t>(B) * np), t(N + 1), h(N, base.T / N),
      work(static_cast<std::size_t>(B * bn::values_per_problem<D>(N)));
  for (int b = 0; b < B; ++b) {
    std::copy(batch[b].guess.q.begin(), batch[b].guess.q.end(), q.begin() + b * per);
    for (int i = 0; i < np; ++i) p[b * np + i] = batch[b].params.empty() ? base.model->param_defaults[i] : batch[b].params[i];
  }
  for (int k = 0; k <= N; ++k) t[k] = base.t0 + base.T * k / N;
  t[N] = base.t0 + base.T;
  pardel::batch_sweep::Settings set;
  set.rtol = options.rtol;
  set.max_iterations = options.max_iterations;
  std::vector<bn::State<D>> host(B);
  bn::host_newton<Kernel, D>(B, N, q.data(), t.data(), h.data(), p.data(), np, set, settings.check_every, work.data(),
                             host.data());
  const pardel::BatchSummary cpu = pardel::solve_batch(base, options, batch);
  int same_as_cpu = 0;
  for (int b = 0; b < B; ++b) {
    SCOPED_TRACE("problem " + std::to_string(b) + ": cpu: " + cpu.entries[b].summary.message);
    EXPECT_EQ(host[b].s.status, pardel::batch_sweep::converged);
    EXPECT_TRUE(cpu.entries[b].summary.converged());
    const pardel::Problem problem = pardel::detail::entry_problem(base, batch[b]);
    pardel::Trajectory mine = batch[b].guess;
    std::copy(q.begin() + b * per, q.begin() + (b + 1) * per, mine.q.begin());
    EXPECT_EQ(pardel::assess_point(problem, mine, 1).kind, pardel::PointKind::minimum);
    double diff_cpu = 0;
    for (std::size_t i = 0; i < per; ++i) diff_cpu = std::max(diff_cpu, std::fabs(mine.q[i] - cpu.entries[b].trajectory.q[i]));
    same_as_cpu += diff_cpu <= 1e-7;
  }
  std::string why;
  if (!pardel::cuda_device_available(&why)) {
    std::printf("the device part skipped: %s\n", why.c_str());
    return same_as_cpu;
  }
  const pardel::BatchSummary gpu = pardel::solve_batch_cuda(base, options, batch, settings);
  EXPECT_TRUE(gpu.refusal.empty()) << gpu.refusal;
  if (!gpu.refusal.empty()) return same_as_cpu;
  for (int b = 0; b < B; ++b) {
    const pardel::Summary& g = gpu.entries[b].summary;
    SCOPED_TRACE("problem " + std::to_string(b) + ": device: " + g.message);
    EXPECT_EQ(g.termination, pardel::Termination::converged);
    EXPECT_LE(std::labs(g.iterations - host[b].s.iterations), 2);
    EXPECT_EQ(g.point.kind, pardel::PointKind::minimum);
    double diff = 0;
    for (std::size_t i = 0; i < per; ++i) diff = std::max(diff, std::fabs(gpu.entries[b].trajectory.q[i] - q[b * per + i]));
    EXPECT_LE(diff, 1e-8);
  }
  return same_as_cpu;
}

struct FuelKernel {
  PARDEL_HD static void full(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                             double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {
    fuel_nav_trapezoid_full(h, t0, t1, q0, q1, p, Ld, D1, D2, D11, D12, D22);
  }
};
struct ZermeloKernel {
  PARDEL_HD static void full(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                             double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {
    zermelo_trapezoid_full(h, t0, t1, q0, q1, p, Ld, D1, D2, D11, D12, D22);
  }
};

TEST(DeviceNewton, FuelNavigationAsOnTheHostPath) {
  const pardel::Problem base = problem_of(fuel_nav_model, 30, 200, {0, 0}, {6, 5});
  const int same = compare_newton<FuelKernel>(base, random_batch(base, 96, 1.0, 0, 1.5, 3));
  std::printf("fuel navigation: %d of 96 answers are the CPU Newton's\n", same);
}

TEST(DeviceNewton, ZermeloRoutesAsOnTheHostPath) {
  const pardel::Problem base = problem_of(zermelo_model, 1, 80, {0, 0}, {6, 2});
  // Polylines between the vortices, each bend moved at random (a straight line through a vortex is
  // no place to start: both Newtons stall on its singularity).
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::vector<pardel::BatchProblem> batch(96);
  for (pardel::BatchProblem& bp : batch)
    bp.guess = pardel::polyline_guess(base, {{0, 0}, {1 + u(rng), 3.5 + u(rng)}, {4 + u(rng), 5.5 + u(rng)}, {6, 2}});
  const int same = compare_newton<ZermeloKernel>(base, batch);
  std::printf("Zermelo: %d of 96 answers are the CPU Newton's\n", same);
}

TEST(DeviceSolve, OptionsDeviceCudaRunsSolveOnTheDevice) {
  pardel::enable_cuda();
  const pardel::Problem base = problem_of(fuel_nav_model, 5, 30, {0, 0}, {1.5, 1});
  pardel::Options o = options_of(pardel::Method::hybrid, 100);
  o.device = pardel::Device::cuda;
  pardel::Trajectory tr = pardel::linear_guess(base);
  pardel::Summary s = pardel::solve(base, o, tr);
  EXPECT_EQ(s.termination, pardel::Termination::invalid_input);
  EXPECT_NE(s.message.find("device cuda: the device solves with methods jacobi, jacobi-newton, newton and auto"),
            std::string::npos)
      << s.message;
  PARDEL_NEEDS_DEVICE();
  o.method = pardel::Method::jacobi_newton;
  o.max_iterations = 20000;
  s = pardel::solve(base, o, tr);
  pardel::Options cpu = o;
  cpu.device = pardel::Device::cpu;
  pardel::Trajectory reference = pardel::linear_guess(base);
  const pardel::Summary c = pardel::solve(base, cpu, reference);
  EXPECT_EQ(s.termination, c.termination) << s.message << " | " << c.message;
  EXPECT_TRUE(c.converged()) << c.message;
  EXPECT_LE(std::labs(s.iterations - c.iterations), 2 + c.iterations / 100);
  double diff = 0;
  for (std::size_t i = 0; i < tr.q.size(); ++i) diff = std::max(diff, std::fabs(tr.q[i] - reference.q[i]));
  EXPECT_LE(diff, 1e-8);
}

#ifdef PARDEL_HAVE_DEVICE_TEST_MODEL
TEST(DeviceModel, AModelAddedWithPardelAddModelIsOnTheDevice) {
  // Registered when the program starts by the static object of its device source.
  const pardel_discretization* midpoint = pardel::find_discretization(double_swing_model, "midpoint");
  ASSERT_NE(midpoint, nullptr);
  std::string why;
  EXPECT_TRUE(pardel::cuda_supports(double_swing_model, *midpoint, &why)) << why;
  EXPECT_TRUE(pardel::cuda_supports(fuel_nav_model, fuel_nav_model.discretizations[0], &why)) << why;
}

TEST(DeviceModel, ADoubleSwingBatchAsOnTheCpu) {
  PARDEL_NEEDS_DEVICE();
  const pardel::Problem base = problem_of(double_swing_model, 1.2, 40, {0.2, -0.3}, {0.5, 0.4});
  EXPECT_GT(compare(base, options_of(pardel::Method::jacobi_newton, 20000), random_batch(base, 24, 0.3, 0.3, 0.3, 7)),
            12);
}
#endif

}  // namespace

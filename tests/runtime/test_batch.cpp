/**
 * @file test_batch.cpp
 * solve_batch on barrier_channel (a particle in the channel |x| < 1 under a constant force, held off
 * the walls by a logarithmic barrier): every entry equals solve() of that problem with one thread,
 * bit for bit, with one and with two batch threads; an entry without barrier matches the exact
 * parabola; bad input, a non-finite Lagrangian and converged problems in one batch each get their
 * own status; the memory check and the stop (Options::keep_going).
 */
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "barrier_channel.hpp"
#include "pardel/pardel.hpp"

namespace {

pardel::Problem base_problem() {
  pardel::Problem p;
  p.model = &barrier_channel_model;
  p.discretization = &barrier_channel_model.discretizations[0];
  p.T = 2;
  p.N = 64;
  p.q0 = {0, 0};
  p.qN = {0.5, 1};
  return p;
}

/** Params in declaration order: gx, gy, w. */
std::vector<double> params(double gx, double gy, double w) { return {gx, gy, w}; }

/** Twelve problems: boundary values, forces and barrier weights varied; two with their own guess. */
std::vector<pardel::BatchProblem> varied_problems(const pardel::Problem& base) {
  std::vector<pardel::BatchProblem> problems;
  for (int i = 0; i < 12; ++i) {
    pardel::BatchProblem b;
    b.q0 = {-0.6 + 0.1 * i, 0.2 * i};
    b.qN = {0.7 - 0.05 * i, -1.0 + 0.3 * i};
    b.params = params(0.4 - 0.1 * i, -1 + 0.2 * i, 0.05 * (i % 5));
    if (i % 5 == 3) {
      pardel::Problem p = base;
      p.q0 = b.q0;
      p.qN = b.qN;
      b.guess = pardel::polyline_guess(p, {b.q0, {0.3, 2.0}, b.qN});
    }
    problems.push_back(b);
  }
  return problems;
}

/** solve() of one batch entry's problem, alone, with one thread. */
pardel::BatchEntry alone(const pardel::Problem& base, const pardel::Options& options, const pardel::BatchProblem& b) {
  pardel::Problem p = base;
  if (!b.q0.empty()) p.q0 = b.q0;
  if (!b.qN.empty()) p.qN = b.qN;
  if (!b.params.empty()) p.params = b.params;
  pardel::Options o = options;
  o.threads = 1;
  pardel::BatchEntry e;
  e.trajectory = b.guess.N > 0 ? b.guess : pardel::linear_guess(p);
  e.summary = pardel::solve(p, o, e.trajectory);
  return e;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void expect_same(const pardel::BatchEntry& got, const pardel::BatchEntry& want, std::size_t i) {
  SCOPED_TRACE("entry " + std::to_string(i));
  EXPECT_EQ(got.summary.termination, want.summary.termination) << got.summary.message;
  EXPECT_EQ(got.summary.message, want.summary.message);
  EXPECT_EQ(got.summary.iterations, want.summary.iterations);
  EXPECT_EQ(got.summary.method, want.summary.method);
  EXPECT_TRUE(same_bits(got.summary.residual, want.summary.residual));
  EXPECT_TRUE(same_bits(got.summary.action, want.summary.action));
  EXPECT_TRUE(same_bits(got.summary.error_estimate, want.summary.error_estimate));
  EXPECT_EQ(got.summary.point.kind, want.summary.point.kind);
  EXPECT_EQ(got.summary.point.positive, want.summary.point.positive);
  EXPECT_EQ(got.summary.point.negative, want.summary.point.negative);
  EXPECT_TRUE(same_bits(got.summary.point.lambda_min, want.summary.point.lambda_min));
  ASSERT_EQ(got.summary.history.size(), want.summary.history.size());
  for (std::size_t r = 0; r < got.summary.history.size(); ++r)
    EXPECT_TRUE(same_bits(got.summary.history[r].residual, want.summary.history[r].residual));
  EXPECT_EQ(got.trajectory.N, want.trajectory.N);
  EXPECT_TRUE(same_bits(got.trajectory.q, want.trajectory.q));
  EXPECT_TRUE(same_bits(got.trajectory.t, want.trajectory.t));
}

TEST(SolveBatch, EveryEntryIsTheSolveAloneWithOneOrTwoThreads) {
  const pardel::Problem base = base_problem();
  const std::vector<pardel::BatchProblem> problems = varied_problems(base);
  pardel::Options options;  // auto, error estimate on: the coarse solves run inside the batch too
  std::vector<pardel::BatchEntry> want;
  for (const auto& b : problems) want.push_back(alone(base, options, b));
  for (int threads : {1, 2}) {
    SCOPED_TRACE("threads " + std::to_string(threads));
    options.threads = threads;
    const pardel::BatchSummary batch = pardel::solve_batch(base, options, problems);
    EXPECT_EQ(batch.refusal, "");
    EXPECT_EQ(batch.threads, threads);
    ASSERT_EQ(batch.entries.size(), problems.size());
    EXPECT_EQ(batch.converged, static_cast<long>(problems.size()));
    for (std::size_t i = 0; i < problems.size(); ++i) {
      expect_same(batch.entries[i], want[i], i);
      EXPECT_EQ(batch.entries[i].summary.threads, 1);
      EXPECT_EQ(batch.entries[i].summary.point.kind, pardel::PointKind::minimum);
    }
  }
}

TEST(SolveBatch, EntryWithoutBarrierIsTheExactParabola) {
  // w = 0: x'' = gx, y'' = gy, whose parabolas the trapezoid rule reproduces at the nodes.
  const pardel::Problem base = base_problem();
  const double gx = 0.3, gy = -1.5, T = base.T;
  const std::vector<double> q0 = {-0.4, 0.25}, qN = {0.6, -0.5};
  std::vector<pardel::BatchProblem> problems(3);
  problems[0].params = params(0, 0, 0.2);
  problems[1] = {q0, qN, params(gx, gy, 0), {}};
  problems[2].params = params(-0.2, 1, 0.1);
  pardel::Options options;
  options.threads = 2;
  const pardel::BatchSummary batch = pardel::solve_batch(base, options, problems);
  const pardel::BatchEntry& e = batch.entries[1];
  ASSERT_TRUE(e.summary.converged()) << e.summary.message;
  const double g[2] = {gx, gy};
  double worst = 0;
  for (int k = 0; k <= e.trajectory.N; ++k) {
    const double t = e.trajectory.t[static_cast<std::size_t>(k)];
    for (int i = 0; i < 2; ++i) {
      const double exact = q0[i] + (qN[i] - q0[i] - g[i] * T * T / 2) * t / T + g[i] * t * t / 2;
      worst = std::max(worst, std::abs(e.trajectory.node(k)[i] - exact));
    }
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_EQ(batch.converged, 3);
}

TEST(SolveBatch, EachProblemGetsItsOwnStatus) {
  const pardel::Problem base = base_problem();
  std::vector<pardel::BatchProblem> problems = varied_problems(base);
  problems.resize(6);
  problems[1].q0 = {0, 0, 0};                                         // wrong size
  problems[2].params = params(0, std::nan(""), 0.1);                  // not finite
  problems[4].q0 = {0, 0};  // the straight line to x = 2 meets the wall x = 1 at node 32: the barrier is infinite
  problems[4].qN = {2, 0};
  pardel::Options options;
  options.threads = 2;
  const pardel::BatchSummary batch = pardel::solve_batch(base, options, problems);
  ASSERT_EQ(batch.entries.size(), problems.size());
  EXPECT_EQ(batch.entries[1].summary.termination, pardel::Termination::invalid_input);
  EXPECT_NE(batch.entries[1].summary.message.find("problem.q0 has 3 values"), std::string::npos)
      << batch.entries[1].summary.message;
  EXPECT_EQ(batch.entries[2].summary.termination, pardel::Termination::invalid_input);
  EXPECT_NE(batch.entries[2].summary.message.find("problem.params"), std::string::npos);
  EXPECT_FALSE(batch.entries[4].summary.converged()) << batch.entries[4].summary.message;
  EXPECT_NE(batch.entries[4].summary.termination, pardel::Termination::invalid_input);
  for (std::size_t i : {0, 3, 5}) EXPECT_TRUE(batch.entries[i].summary.converged()) << i;
  EXPECT_EQ(batch.converged, 3);
  for (std::size_t i = 0; i < problems.size(); ++i) {
    if (i == 1) continue;  // no straight line to start from: solve() alone would need a guess
    expect_same(batch.entries[i], alone(base, options, problems[i]), i);
  }
}

TEST(SolveBatch, KeepGoingStopsTheBatch) {
  const pardel::Problem base = base_problem();
  std::vector<pardel::BatchProblem> problems;
  for (int r = 0; r < 5; ++r)
    for (const auto& b : varied_problems(base)) problems.push_back(b);
  pardel::Options options;
  options.threads = 2;
  std::atomic<long> polls{0};
  options.keep_going = [&polls] { return polls.fetch_add(1) < 40; };
  const pardel::BatchSummary batch = pardel::solve_batch(base, options, problems);
  long interrupted = 0, not_started = 0;
  for (const auto& e : batch.entries) {
    EXPECT_TRUE(e.summary.converged() || e.summary.termination == pardel::Termination::interrupted)
        << pardel::to_string(e.summary.termination) << ": " << e.summary.message;
    if (e.summary.termination == pardel::Termination::interrupted) ++interrupted;
    if (e.summary.message == "not started: the batch was interrupted") {
      ++not_started;
      EXPECT_EQ(e.trajectory.N, 0);
    }
  }
  EXPECT_GT(not_started, 40);  // 60 problems, 40 polls: most never start
  EXPECT_EQ(interrupted + batch.converged, static_cast<long>(problems.size()));

  options.keep_going = [] { return false; };
  const pardel::BatchSummary none = pardel::solve_batch(base, options, problems);
  EXPECT_EQ(none.converged, 0);
  for (const auto& e : none.entries) EXPECT_EQ(e.summary.termination, pardel::Termination::interrupted);
}

TEST(SolveBatch, RefusesABatchTooLargeForTheMachineAndBadOptions) {
  pardel::Problem base = base_problem();
  base.N = 50000000;  // 1000 returned trajectories of 50 million nodes: 1.2 TB
  std::vector<pardel::BatchProblem> problems(1000);
  pardel::Options options;
  options.threads = 2;
  const pardel::BatchSummary batch = pardel::solve_batch(base, options, problems);
  EXPECT_NE(batch.refusal.find("a batch of 1000 problems: grid.N = 50000000 needs an estimated"), std::string::npos)
      << batch.refusal;
  EXPECT_TRUE(batch.entries.empty());
  EXPECT_EQ(batch.converged, 0);

  base = base_problem();
  problems.resize(2);
  options.threads = -1;
  EXPECT_NE(pardel::solve_batch(base, options, problems).refusal.find("threads"), std::string::npos);
  options.threads = 1;
  pardel::SolverState state;
  options.resume_from = &state;
  EXPECT_NE(pardel::solve_batch(base, options, problems).refusal.find("resume_from"), std::string::npos);
}

TEST(SolveBatch, EmptyBatch) {
  const pardel::BatchSummary batch = pardel::solve_batch(base_problem(), pardel::Options{}, {});
  EXPECT_TRUE(batch.entries.empty());
  EXPECT_EQ(batch.refusal, "");
  EXPECT_EQ(batch.converged, 0);
}

}  // namespace

TEST(SolveBatch, DeviceCudaWithoutTheCudaSolversIsRefusedWithTheReason) {
  // This program links the runtime alone (no pardel::cuda, no enable_cuda()).
  const pardel::Problem base = base_problem();
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.device = pardel::Device::cuda;
  const pardel::BatchSummary batch = pardel::solve_batch(base, options, varied_problems(base));
  EXPECT_TRUE(batch.entries.empty());
  EXPECT_NE(batch.refusal.find("device cuda: this program has no solver for it"), std::string::npos) << batch.refusal;
  pardel::Trajectory tr = pardel::linear_guess(base);
  const std::vector<double> before = tr.q;
  const pardel::Summary s = pardel::solve(base, options, tr);
  EXPECT_EQ(s.termination, pardel::Termination::invalid_input);
  EXPECT_NE(s.message.find("pardel::enable_cuda()"), std::string::npos) << s.message;
  EXPECT_EQ(tr.q, before);
}

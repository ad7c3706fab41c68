// Checkpoint and resume in the runtime: a solve interrupted through Options::on_iteration at
// iteration K hands back a SolverState; a solve resumed from it must reach what the uninterrupted
// solve reaches — the same iterates bit for bit (every method, with coarse-to-fine refinement, with
// both clocks, after repeated interruptions) — and a state that does not fit the problem or the
// options is refused with invalid_input and a message naming what is wrong. A warm start
// (Options::warm_start) continues from the state's iterate with other options, possibly on
// another grid, with the count and the history continued.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "pardel/pardel.hpp"

namespace {

using pardel::Method;
using pardel::Options;
using pardel::Problem;
using pardel::Summary;
using pardel::Termination;
using pardel::Trajectory;

/** The seed's fuel-optimal navigation example (scenes/fuel_nav.toml) at N intervals. */
Problem fuel_nav(int N) {
  Problem p;
  p.model = pardel::find_model("fuel_nav");
  p.discretization = p.model ? pardel::find_discretization(*p.model, "trapezoid") : nullptr;
  p.t0 = 0;
  p.T = 30;
  p.N = N;
  p.q0 = {0, 0};
  p.qN = {6, 5};
  return p;
}

/** The Bratu problem u'' + lambda e^u = 0 (lambda = 2) from u = 0 to u = 0.3 on [0, 1]. */
Problem bratu(int N) {
  Problem p;
  p.model = pardel::find_model("bratu");
  p.discretization = p.model ? pardel::find_discretization(*p.model, "trapezoid") : nullptr;
  p.params = {2.0};
  p.N = N;
  p.q0 = {0};
  p.qN = {0.3};
  return p;
}

/** Zermelo's problem in a time-varying wind, free final time (scenes/zermelo_tv.toml). */
Problem zermelo_tv(int N) {
  Problem p;
  p.model = pardel::find_model("zermelo_tv");
  p.discretization = p.model ? pardel::find_discretization(*p.model, "trapezoid") : nullptr;
  p.T = 1;
  p.N = N;
  p.q0 = {1, 6};
  p.qN = {6, 2};
  p.clock = pardel::ClockMode::free_final_time;
  return p;
}

/** The spacecraft transfer with Sundman's adaptive step (scenes/spacecraft_sundman.toml). */
Problem spacecraft_sundman(int N) {
  Problem p;
  p.model = pardel::find_model("spacecraft");
  p.discretization = p.model ? pardel::find_discretization(*p.model, "trapezoid(alpha=1)") : nullptr;
  p.T = 0.13761699442396208;
  p.N = N;
  p.q0 = {-0.00028185006780313756, 0, 0, -0.10294753382194759};
  p.qN = {0.0020378554360866549, 0.0015651707922623602, -0.019359200263837129, 0.025205716648293883};
  p.clock = pardel::ClockMode::fixed_total_time;
  return p;
}

struct SolveRun {
  Summary summary;
  Trajectory trajectory;
};

/** Solves from the straight line (or from `resume`), interrupting at the first recorded iteration
 *  >= `stop_at` (< 0: never; records are geometrically spaced after the first 1000). */
SolveRun run(const Problem& problem, Options options, long stop_at, const pardel::SolverState* resume = nullptr) {
  options.on_iteration = [stop_at](const pardel::IterationRecord& r) { return stop_at < 0 || r.iteration < stop_at; };
  options.resume_from = resume;
  SolveRun out;
  out.trajectory = pardel::linear_guess(problem);
  out.summary = pardel::solve(problem, options, out.trajectory);
  return out;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

/** Interrupts at (the first record at or after) each K in `stops` in turn (resuming in between), then runs to the end, and compares
 *  with the uninterrupted solve: same termination, iterations, trajectory and node times bit for bit,
 *  same history except wall times. */
void expect_resume_reproduces(const Problem& problem, const Options& options, const std::vector<long>& stops) {
  ASSERT_NE(problem.model, nullptr) << "bundled model missing";
  const SolveRun reference = run(problem, options, -1);
  pardel::SolverState state;
  for (long K : stops) {
    const SolveRun part = run(problem, options, K, state.valid ? &state : nullptr);
    ASSERT_EQ(part.summary.termination, Termination::interrupted) << "K = " << K << ": " << part.summary.message;
    ASSERT_TRUE(part.summary.state.valid);
    EXPECT_GE(part.summary.state.iteration, K);
    EXPECT_EQ(part.summary.iterations, part.summary.state.iteration);
    state = part.summary.state;
  }
  const SolveRun resumed = run(problem, options, -1, &state);
  SCOPED_TRACE(std::string("method ") + pardel::to_string(options.method) + ", reference: " +
               reference.summary.brief_report());
  EXPECT_EQ(resumed.summary.termination, reference.summary.termination) << resumed.summary.message;
  EXPECT_EQ(resumed.summary.iterations, reference.summary.iterations);
  EXPECT_EQ(resumed.trajectory.N, reference.trajectory.N);
  EXPECT_TRUE(same_bits(resumed.trajectory.q, reference.trajectory.q)) << "iterates differ";
  EXPECT_TRUE(same_bits(resumed.trajectory.t, reference.trajectory.t)) << "node times differ";
  EXPECT_EQ(resumed.summary.residual, reference.summary.residual);
  EXPECT_EQ(resumed.summary.action, reference.summary.action);
  ASSERT_EQ(resumed.summary.history.size(), reference.summary.history.size());
  for (std::size_t i = 0; i < reference.summary.history.size(); ++i) {
    EXPECT_EQ(resumed.summary.history[i].iteration, reference.summary.history[i].iteration) << i;
    EXPECT_EQ(resumed.summary.history[i].N, reference.summary.history[i].N) << i;
    EXPECT_EQ(resumed.summary.history[i].residual, reference.summary.history[i].residual) << i;
    EXPECT_EQ(resumed.summary.history[i].action, reference.summary.history[i].action) << i;
  }
}

Options with(Method method) {
  Options o;
  o.method = method;
  o.tol = 1e-10;
  o.threads = 2;
  return o;
}

TEST(CheckpointResume, JacobiNewtonIsBitForBit) {
  Options o = with(Method::jacobi_newton);
  o.max_iterations = 3000;  // the reference ends at max_iterations: same iterate count either way
  expect_resume_reproduces(fuel_nav(60), o, {700});
}

TEST(CheckpointResume, JacobiNewtonConvergedAfterTwoInterruptions) {
  Options o = with(Method::jacobi_newton);
  o.damping = 0.1;
  expect_resume_reproduces(bratu(40), o, {5, 1500});
}

TEST(CheckpointResume, NonlinearJacobiIsBitForBit) {
  Options o = with(Method::jacobi);
  expect_resume_reproduces(bratu(40), o, {30});
}

TEST(CheckpointResume, NewtonKeepsItsShift) {
  // Interrupted in the middle of the trust-region phase: the radius, the shift, the best residual,
  // the escapes and the watchdog (10 values while it is not active) travel in the state, so the
  // resumed iterates are the same, not merely as accurate.
  Options o = with(Method::newton);
  expect_resume_reproduces(fuel_nav(200), o, {2});
  const SolveRun part = run(fuel_nav(200), o, 2);
  ASSERT_EQ(part.summary.state.method_state.size(), 10u);
  const SolveRun resumed = run(fuel_nav(200), o, -1, &part.summary.state);
  ASSERT_TRUE(resumed.summary.converged()) << resumed.summary.message;
  EXPECT_LE(pardel::residual_norm(fuel_nav(200), resumed.trajectory), o.tol);
}

TEST(CheckpointResume, NewtonWithCyclicReduction) {
  Options o = with(Method::newton);
  o.linear_solver = pardel::LinearSolver::cyclic_reduction;
  expect_resume_reproduces(fuel_nav(200), o, {3});
}

TEST(CheckpointResume, HybridInBothPhases) {
  Options o = with(Method::hybrid);
  const Problem p = fuel_nav(50);
  const SolveRun reference = run(p, o, -1);
  ASSERT_TRUE(reference.summary.converged()) << reference.summary.message;
  ASSERT_LT(reference.summary.iterations, 1000) << "every iteration must be a record";
  // Early: still sweeping; late: in the Newton phase (the iteration before the last).
  const long late = reference.summary.iterations - 1;
  const SolveRun early_part = run(p, o, 3);
  ASSERT_EQ(early_part.summary.state.method_state.size(), 12u);
  EXPECT_EQ(early_part.summary.state.method_state[0], 0.0) << "expected the sweep phase at iteration 3";
  const SolveRun late_part = run(p, o, late);
  ASSERT_GE(late_part.summary.state.method_state.size(), 12u);
  EXPECT_EQ(late_part.summary.state.method_state[0], 1.0) << "expected the Newton phase at iteration " << late;
  expect_resume_reproduces(p, o, {3});
  expect_resume_reproduces(p, o, {late});
}

TEST(CheckpointResume, CoarseToFineRefinement) {
  Options o = with(Method::jacobi_newton);
  o.refine_start_N = 8;
  o.refine_factor = 1.5;
  const SolveRun reference = run(bratu(60), o, -1);
  ASSERT_TRUE(reference.summary.converged()) << reference.summary.message;
  // One stop on the coarsest level, one on a later level.
  const auto& h = reference.summary.history;
  long later = -1;
  for (const auto& r : h)
    if (r.N > 8 && r.N < 60) {
      later = r.iteration + 3;
      break;
    }
  ASSERT_GT(later, 5);
  expect_resume_reproduces(bratu(60), o, {5, later});
  const SolveRun part = run(bratu(60), o, later);
  EXPECT_GT(part.summary.state.level, 0);
  EXPECT_LT(part.summary.state.N, 60);
}

TEST(CheckpointResume, FreeFinalTimeClock) {
  Options o = with(Method::jacobi_newton);
  o.clock_update_every = 100;
  o.max_iterations = 1500;
  // 250: between two node-time updates, so the saved times are not those of the saved iterate.
  expect_resume_reproduces(zermelo_tv(50), o, {250, 1001});
}

TEST(CheckpointResume, FixedTotalTimeClockWithNewton) {
  Options o = with(Method::newton);
  o.tol = 1e-7;
  o.clock_update_every = 5;
  // From the straight line Newton wanders under this clock for tens of thousands of iterations;
  // 200 of them (40 clock updates) are enough to compare: the reference ends at max_iterations.
  o.max_iterations = 200;
  expect_resume_reproduces(spacecraft_sundman(100), o, {7, 123});
}

// ---- warm starts -------------------------------------------------------------------------------

/** Largest |a_i - b_i|. */
double max_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double m = a.size() == b.size() ? 0.0 : INFINITY;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) m = std::max(m, std::fabs(a[i] - b[i]));
  return m;
}

/** Jacobi-Newton interrupted at iteration 200 of Bratu's problem at N = n_state; the state. */
pardel::SolverState interrupted_bratu(int n_state) {
  const SolveRun part = run(bratu(n_state), with(Method::jacobi_newton), 200);
  EXPECT_EQ(part.summary.termination, Termination::interrupted) << part.summary.message;
  return part.summary.state;
}

TEST(WarmStart, NewtonContinuesAJacobiNewtonRun) {
  ASSERT_NE(bratu(40).model, nullptr);
  const pardel::SolverState state = interrupted_bratu(40);
  ASSERT_TRUE(state.valid);
  Options newton = with(Method::newton);
  newton.warm_start = true;
  const SolveRun warm = run(bratu(40), newton, -1, &state);
  ASSERT_EQ(warm.summary.termination, Termination::converged) << warm.summary.message;
  EXPECT_NE(warm.summary.message.find("(warm start from iteration " + std::to_string(state.iteration) +
                                      " of jacobi-newton at N = 40)"),
            std::string::npos)
      << warm.summary.message;
  // The count and the history continue the interrupted run's.
  EXPECT_GT(warm.summary.iterations, state.iteration);
  ASSERT_GT(warm.summary.history.size(), state.history.size());
  for (std::size_t i = 0; i < state.history.size(); ++i) {
    EXPECT_EQ(warm.summary.history[i].iteration, state.history[i].iteration) << i;
    EXPECT_EQ(warm.summary.history[i].residual, state.history[i].residual) << i;
  }
  for (std::size_t i = 1; i < warm.summary.history.size(); ++i)
    EXPECT_GT(warm.summary.history[i].iteration, warm.summary.history[i - 1].iteration) << i;
  // The answer is Newton's from the straight line (Bratu's lower solution).
  const SolveRun fresh = run(bratu(40), with(Method::newton), -1);
  ASSERT_EQ(fresh.summary.termination, Termination::converged) << fresh.summary.message;
  EXPECT_LT(max_difference(warm.trajectory.q, fresh.trajectory.q), 1e-9);
}

TEST(WarmStart, OnAFinerGridTheIterateIsResampled) {
  ASSERT_NE(bratu(40).model, nullptr);
  const pardel::SolverState state = interrupted_bratu(40);
  ASSERT_TRUE(state.valid);
  Options newton = with(Method::newton);
  newton.warm_start = true;
  const SolveRun warm = run(bratu(80), newton, -1, &state);
  ASSERT_EQ(warm.summary.termination, Termination::converged) << warm.summary.message;
  EXPECT_EQ(warm.trajectory.N, 80);
  EXPECT_EQ(warm.summary.history.back().N, 80);
  EXPECT_EQ(warm.summary.history.front().N, 40);
  const SolveRun fresh = run(bratu(80), with(Method::newton), -1);
  ASSERT_EQ(fresh.summary.termination, Termination::converged) << fresh.summary.message;
  EXPECT_LT(max_difference(warm.trajectory.q, fresh.trajectory.q), 1e-9);
}

TEST(WarmStart, AStateThatDoesNotFitIsRefused) {
  ASSERT_NE(bratu(40).model, nullptr);
  pardel::SolverState state = interrupted_bratu(40);
  state.trajectory.q[5] = NAN;
  Options newton = with(Method::newton);
  newton.warm_start = true;
  const SolveRun r = run(bratu(40), newton, -1, &state);
  EXPECT_EQ(r.summary.termination, Termination::invalid_input);
  EXPECT_NE(r.summary.message.find("resume: the saved trajectory does not fit the problem: trajectory has a non-finite value at node 5"), std::string::npos)
      << r.summary.message;
}

// ---- states that do not fit -----------------------------------------------------------------

class MisfitState : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NE(fuel_nav(30).model, nullptr);
    options_ = with(Method::jacobi_newton);
    state_ = run(fuel_nav(30), options_, 10).summary.state;
    ASSERT_TRUE(state_.valid);
  }
  void expect_refused(const Problem& problem, const Options& options, const pardel::SolverState& state,
                      const std::string& expected) {
    const SolveRun r = run(problem, options, -1, &state);
    EXPECT_EQ(r.summary.termination, Termination::invalid_input) << r.summary.message;
    EXPECT_NE(r.summary.message.find(expected), std::string::npos) << r.summary.message;
  }
  Options options_;
  pardel::SolverState state_;
};

TEST_F(MisfitState, OtherMethod) {
  Options o = with(Method::newton);
  expect_refused(fuel_nav(30), o, state_, "resume: the state is of method jacobi-newton, the options ask for newton");
}

TEST_F(MisfitState, OtherGrid) {
  expect_refused(fuel_nav(31), options_, state_, "resume: refinement level 0 with N = 30 is not a level");
}

TEST_F(MisfitState, TruncatedTrajectory) {
  pardel::SolverState s = state_;
  s.trajectory.q.pop_back();
  expect_refused(fuel_nav(30), options_, s, "resume: the saved trajectory does not fit the problem");
}

TEST_F(MisfitState, NonFiniteIterate) {
  pardel::SolverState s = state_;
  s.trajectory.q[7] = std::nan("");
  expect_refused(fuel_nav(30), options_, s, "resume: the saved trajectory does not fit the problem: trajectory has a non-finite value");
}

TEST_F(MisfitState, MethodStateOfAnotherMethod) {
  pardel::SolverState s = state_;
  s.method_state = {0.5, 2.0};
  expect_refused(fuel_nav(30), options_, s, "do not fit it");
}

TEST_F(MisfitState, EmptyState) {
  expect_refused(fuel_nav(30), options_, pardel::SolverState{}, "resume: the solver state is empty");
}

TEST_F(MisfitState, WallTimeThatIsNotADuration) {
  pardel::SolverState s = state_;
  s.seconds = std::nan("");
  expect_refused(fuel_nav(30), options_, s, "resume: the recorded wall time is not a duration in seconds");
  s.seconds = -1;
  expect_refused(fuel_nav(30), options_, s, "resume: the recorded wall time is not a duration in seconds");
}

TEST_F(MisfitState, InconsistentCounters) {
  pardel::SolverState s = state_;
  s.level_iteration = s.iteration + 1;
  expect_refused(fuel_nav(30), options_, s, "resume: inconsistent iteration counters");
}

}  // namespace

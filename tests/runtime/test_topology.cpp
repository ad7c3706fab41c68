/**
 * @file test_topology.cpp
 * The solve written once over a topology (runtime/src/topology.hpp): a topology that delegates
 * every member to OneProcess gives pardel::solve's result bit for bit (levels, the methods, resume),
 * and one that does not run stationary-newton, like the MPI ranks' topology, gets the automatic
 * method's first attempt with a note that says why no second attempt was made. The same checks
 * over real MPI ranks: tests/mpi/test_distributed.cpp.
 */
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"
#include "topology.hpp"

namespace {

using pardel::detail::Context;
using pardel::detail::Method_;
using pardel::detail::OneProcess;

/** A topology that forwards every member to a OneProcess; `stationary` false refuses
 *  stationary-newton as the MPI ranks' topology does. Counts the levels it sets up. */
class Forwarding final : public pardel::detail::Topology {
 public:
  explicit Forwarding(bool stationary, int* levels) : stationary_(stationary), levels_(levels) {}

  void update_times(Context& ctx, pardel::detail::Positions positions) override { inner_.update_times(ctx, positions); }
  void check_next(const Context& ctx, const pardel::detail::StepOutcome& outcome, int* node, double* qmax) override {
    inner_.check_next(ctx, outcome, node, qmax);
  }
  double action(Context& ctx) override { return inner_.action(ctx); }
  Context& context() override { return inner_.context(); }
  std::string unsupported(const pardel::Problem&, const pardel::Options& options) const override {
    if (!stationary_ && options.method == pardel::Method::stationary_newton) return "not over this topology";
    return {};
  }
  std::unique_ptr<Method_> make_newton(const pardel::Options& options, int dim) override {
    return inner_.make_newton(options, dim);
  }
  std::unique_ptr<Method_> make_stationary_newton(const pardel::Options& options, int dim) override {
    return stationary_ ? inner_.make_stationary_newton(options, dim) : nullptr;
  }
  void reserve(int N) override { inner_.reserve(N); }
  bool set_up(const pardel::Problem& problem, int N, int threads, const pardel::Trajectory& from,
              std::string* message) override {
    ++*levels_;
    return inner_.set_up(problem, N, threads, from, message);
  }
  bool set_up_resumed(const pardel::Problem& problem, const pardel::SolverState& st, int threads,
                      std::string* message) override {
    ++*levels_;
    return inner_.set_up_resumed(problem, st, threads, message);
  }
  bool lagrangian_regular(const pardel::Problem& problem, std::string* message) override {
    return inner_.lagrangian_regular(problem, message);
  }
  void gather(bool everywhere, pardel::Trajectory& out) override { inner_.gather(everywhere, out); }
  void refine(const pardel::Options& options, pardel::Summary& summary) override { inner_.refine(options, summary); }
  void assess(const pardel::Options& options, pardel::PointAssessment& out) override { inner_.assess(options, out); }
  void interior_inertia(pardel::detail::Inertia& out) override { inner_.interior_inertia(out); }

 private:
  OneProcess inner_;
  bool stationary_;
  int* levels_;
};

pardel::Problem harmonic(double T, int N) {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = pardel::find_discretization(hand::harmonic, "trapezoid");
  p.params = {1.0};
  p.T = T;
  p.N = N;
  p.q0 = {0.0};
  p.qN = {1.0};
  return p;
}

pardel::Summary forwarded(const pardel::Problem& problem, const pardel::Options& options, pardel::Trajectory& tr,
                          bool stationary, int* levels) {
  return pardel::detail::solve_over(problem, options, tr,
                                    [&] { return std::make_unique<Forwarding>(stationary, levels); });
}

void expect_same(const pardel::Summary& a, const pardel::Trajectory& ta, const pardel::Summary& b,
                 const pardel::Trajectory& tb) {
  EXPECT_EQ(a.termination, b.termination) << a.message << " | " << b.message;
  EXPECT_EQ(a.message, b.message);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.residual, b.residual);
  EXPECT_EQ(a.action, b.action);
  EXPECT_EQ(a.point.kind, b.point.kind);
  EXPECT_EQ(a.point.note, b.point.note);
  EXPECT_EQ(a.error_estimate, b.error_estimate);
  EXPECT_EQ(ta.q, tb.q);
}

TEST(Topology, AForwardingTopologyGivesTheOneProcessSolveBitForBit) {
  // Below the conjugate point (omega T = 3 < pi): a minimum, reached by every method.
  const auto problem = harmonic(3.0, 60);
  for (pardel::Method method : {pardel::Method::automatic, pardel::Method::newton, pardel::Method::hybrid,
                                pardel::Method::jacobi_newton}) {
    pardel::Options options;
    options.method = method;
    options.threads = 1;
    options.refine_start_N = 16;
    auto one = pardel::linear_guess(problem), other = one;
    const pardel::Summary s1 = pardel::solve(problem, options, one);
    int levels = 0;
    const pardel::Summary s2 = forwarded(problem, options, other, true, &levels);
    ASSERT_TRUE(s1.converged()) << to_string(method) << ": " << s1.message;
    expect_same(s1, one, s2, other);
    EXPECT_GE(levels, 2) << to_string(method) << ": the levels from N = 16 up, each set up by the topology";
  }
}

TEST(Topology, AnInterruptedSolveResumesOverAnotherTopologyBitForBit) {
  const auto problem = harmonic(3.0, 60);
  pardel::Options options;
  options.method = pardel::Method::jacobi_newton;
  options.threads = 1;
  auto reference = pardel::linear_guess(problem);
  const pardel::Summary whole = pardel::solve(problem, options, reference);
  ASSERT_TRUE(whole.converged()) << whole.message;
  pardel::Options interrupted = options;
  interrupted.on_iteration = [](const pardel::IterationRecord& rec) { return rec.iteration < 5; };
  auto tr = pardel::linear_guess(problem);
  const pardel::Summary first = pardel::solve(problem, interrupted, tr);
  ASSERT_EQ(first.termination, pardel::Termination::interrupted) << first.message;
  pardel::Options resumed = options;
  resumed.resume_from = &first.state;
  int levels = 0;
  const pardel::Summary rest = forwarded(problem, resumed, tr, true, &levels);
  EXPECT_EQ(levels, 3) << "the resumed level, then the error estimate's coarse grid and the third level that checks it";
  EXPECT_EQ(rest.termination, whole.termination) << rest.message;
  EXPECT_EQ(rest.error_estimate, whole.error_estimate);
  EXPECT_EQ(rest.iterations, whole.iterations);
  EXPECT_EQ(rest.residual, whole.residual);
  EXPECT_EQ(tr.q, reference.q);
}

TEST(Topology, WithoutStationaryNewtonTheAutomaticMethodSaysWhyNoSecondAttemptWasMade) {
  // Past the conjugate point (omega T = 4 > pi) the action is unbounded below: the minimizing
  // Newton diverges. In one process stationary-newton then returns the saddle; a topology that
  // does not run it returns the first attempt, which plain Newton reproduces.
  const auto problem = harmonic(4.0, 200);
  pardel::Options automatic;
  automatic.threads = 1;
  auto one = pardel::linear_guess(problem);
  const pardel::Summary both = pardel::solve(problem, automatic, one);
  ASSERT_TRUE(both.converged()) << both.message;
  EXPECT_EQ(both.method, pardel::Method::stationary_newton);

  pardel::Options newton = automatic;
  newton.method = pardel::Method::newton;
  auto alone = pardel::linear_guess(problem);
  const pardel::Summary minimizing = pardel::solve(problem, newton, alone);
  ASSERT_EQ(minimizing.termination, pardel::Termination::diverged) << minimizing.message;

  auto tr = pardel::linear_guess(problem);
  int levels = 0;
  const pardel::Summary s = forwarded(problem, automatic, tr, false, &levels);
  EXPECT_EQ(s.termination, minimizing.termination);
  EXPECT_EQ(s.iterations, minimizing.iterations);
  EXPECT_EQ(s.message, minimizing.message +
                           "; Newton on the DEL residual (stationary-newton), the automatic method's second attempt for "
                           "a model without a declared cost, was not made: not over this topology");
  EXPECT_EQ(s.point.note, minimizing.point.note);
  EXPECT_EQ(tr.q, alone.q);
}

}  // namespace

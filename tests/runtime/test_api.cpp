/**
 * @file test_api.cpp
 * The public API's names and validation: method, termination and linear-solver names round-trip,
 * Options::is_valid names the bad option, its value and its bound's rule (option_bound), problems
 * and trajectories with wrong sizes or non-finite values are invalid_input with a message naming
 * the field, discretizations are found by name, and the Summary's brief report says how the solve
 * ended.
 */
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

pardel::Problem good_problem() {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = &hand::harmonic.discretizations[0];
  p.N = 10;
  p.q0 = {0.0};
  p.qN = {1.0};
  return p;
}

TEST(Api, MethodNamesRoundTrip) {
  for (auto m : {pardel::Method::automatic, pardel::Method::jacobi, pardel::Method::jacobi_newton,
                 pardel::Method::newton, pardel::Method::hybrid}) {
    pardel::Method parsed = pardel::Method::newton;
    ASSERT_TRUE(pardel::parse_method(pardel::to_string(m), &parsed)) << pardel::to_string(m);
    EXPECT_EQ(parsed, m);
  }
  pardel::Method m;
  EXPECT_FALSE(pardel::parse_method("gauss-seidel", &m));
  EXPECT_STREQ(pardel::to_string(pardel::Method::jacobi_newton), "jacobi-newton");
  pardel::LinearSolver ls;
  ASSERT_TRUE(pardel::parse_linear_solver("cyclic-reduction", &ls));
  EXPECT_EQ(ls, pardel::LinearSolver::cyclic_reduction);
  EXPECT_FALSE(pardel::parse_linear_solver("lu", &ls));
  EXPECT_STREQ(pardel::to_string(pardel::Termination::non_finite), "non_finite");
}

TEST(Api, OptionsValidationNamesOptionAndValue) {
  std::string err;
  EXPECT_TRUE(pardel::Options{}.is_valid(&err));
  auto check = [](pardel::Options o, const char* needle) {
    std::string e;
    EXPECT_FALSE(o.is_valid(&e));
    EXPECT_NE(e.find(needle), std::string::npos) << e;
  };
  pardel::Options o;
  o.method = pardel::Method::jacobi_newton;
  o.tol = -1;
  check(o, "tol = -1");
  o = {};
  o.damping = 1.0;
  check(o, "damping = 1");
  o = {};
  o.newton_substeps = 0;
  check(o, "newton_substeps = 0");
  o = {};
  o.threads = -2;
  check(o, "threads = -2");
  o = {};
  o.refine_factor = 1.0;
  check(o, "refine_factor = 1");
  o = {};
  o.refine_start_N = 1;
  check(o, "refine_start_N = 1");
  o = {};
  o.clock_update_every = 0;
  check(o, "clock_update_every = 0");
  o = {};
  o.history_every = 0;
  check(o, "history_every = 0");
  o = {};
  o.tol = std::numeric_limits<double>::quiet_NaN();
  check(o, "tol = nan");
  // solve() reports invalid options without touching the trajectory.
  auto p = good_problem();
  auto traj = pardel::linear_guess(p);
  const auto before = traj.q;
  o = {};
  o.damping = 2;
  const auto s = pardel::solve(p, o, traj);
  EXPECT_EQ(s.termination, pardel::Termination::invalid_input);
  EXPECT_NE(s.message.find("damping"), std::string::npos);
  EXPECT_EQ(traj.q, before);
}

TEST(Api, OptionBoundsAreCheckedByIsValidWithTheirRule) {
  auto error_of = [](const pardel::Options& o) {
    std::string e;
    EXPECT_FALSE(o.is_valid(&e));
    return e;
  };
  pardel::Options o;
  o.newton_substeps = 1001;
  EXPECT_EQ(error_of(o), "option newton_substeps = 1001 is invalid: must be between 1 and 1000");
  o = {};
  o.threads = 4097;
  EXPECT_EQ(error_of(o), std::string("option threads = 4097 is invalid: ") + pardel::option_bound("threads")->rule);
  o = {};
  o.refine_factor = 16.5;
  EXPECT_EQ(error_of(o), "option refine_factor = 16.5 is invalid: must be in (1, 16]");
  o = {};
  o.max_iterations = -1;
  EXPECT_EQ(error_of(o), "option max_iterations = -1 is invalid: must be >= 0 (0: evaluate the start only)");
  o = {};
  o.tol = std::numeric_limits<double>::infinity();
  EXPECT_NE(error_of(o).find("option tol = inf is invalid: must be a finite number >= 0"), std::string::npos);
  // The ends that are included, and the zero of refine_start_N (off).
  o = {};
  o.tol = 0;
  o.max_iterations = 0;
  o.newton_substeps = 1000;
  o.threads = 4096;
  o.refine_factor = 16;
  o.refine_start_N = 0;
  std::string e;
  EXPECT_TRUE(o.is_valid(&e)) << e;
  const pardel::OptionBound* start = pardel::option_bound("refine_start_N");
  ASSERT_NE(start, nullptr);
  EXPECT_TRUE(start->accepts(0));
  EXPECT_FALSE(start->accepts(1));
  EXPECT_TRUE(start->accepts(2));
  EXPECT_FALSE(pardel::option_bound("rtol")->accepts(std::numeric_limits<double>::quiet_NaN()));
  EXPECT_EQ(pardel::option_bound("method"), nullptr);
}

TEST(Api, ProblemValidationNamesTheField) {
  auto expect_invalid = [](const pardel::Problem& p, const pardel::Trajectory& t, const char* needle) {
    std::string e;
    EXPECT_FALSE(pardel::validate(p, t, &e));
    EXPECT_NE(e.find(needle), std::string::npos) << e;
    pardel::Trajectory copy = t;
    const auto s = pardel::solve(p, pardel::Options{}, copy);
    EXPECT_EQ(s.termination, pardel::Termination::invalid_input);
    EXPECT_FALSE(s.brief_report().empty());
  };
  const auto good = good_problem();
  const auto traj = pardel::linear_guess(good);
  std::string e;
  EXPECT_TRUE(pardel::validate(good, traj, &e)) << e;
  auto p = good;
  p.model = nullptr;
  expect_invalid(p, traj, "problem.model");
  p = good;
  p.discretization = nullptr;
  expect_invalid(p, traj, "problem.discretization");
  p = good;
  p.N = 1;
  expect_invalid(p, traj, "problem.N = 1");
  p = good;
  p.q0 = {0.0, 1.0};
  expect_invalid(p, traj, "problem.q0 has 2 values");
  p = good;
  p.qN = {std::numeric_limits<double>::infinity()};
  expect_invalid(p, traj, "problem.qN");
  p = good;
  p.params = {1.0, 2.0};
  expect_invalid(p, traj, "problem.params");
  p = good;
  p.T = 0;
  expect_invalid(p, traj, "problem.T");
  p = good;
  p.knots = {{0.5, {1.0, 2.0}}};
  expect_invalid(p, traj, "problem.knots[0].q");
  auto bad_traj = traj;
  bad_traj.q[3] = std::nan("");
  expect_invalid(good, bad_traj, "node 3");
  bad_traj = traj;
  bad_traj.q.pop_back();
  expect_invalid(good, bad_traj, "trajectory.q");
}

TEST(Api, FindDiscretizationByName) {
  EXPECT_EQ(pardel::find_discretization(hand::harmonic, "midpoint"), &hand::harmonic.discretizations[1]);
  EXPECT_EQ(pardel::find_discretization(hand::harmonic, "gauss2"), nullptr);
  EXPECT_EQ(pardel::find_discretization(hand::spline, "trapezoid( alpha )"), &hand::spline.discretizations[0]);
}

/** A one-coordinate order-2 model with the given discretizations and no kernels: what
 *  find_discretization reads. */
pardel_model order_two_model(const char* name, const pardel_discretization* discs, int count) {
  pardel_model m{};
  m.name = name;
  m.order = 2;
  m.ncoords = 1;
  m.dim = 2;
  m.ndiscretizations = count;
  m.discretizations = discs;
  return m;
}

// A name is found in any spelling pardel-gen accepts in a .lag: the generated names are canonical
// (exact reduced fractions), and a bare name finds the discretization that carries it as its
// bare_name (the generator's default, tests/codegen/test_discretizations.cpp).
TEST(Api, FindDiscretizationByAnySpellingOfItsParameter) {
  const pardel_discretization discs[] = {
      {"trapezoid(alpha=7/10)", 2, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr},
      {"trapezoid(alpha=1)", 2, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, "trapezoid"},
      {"trapezoid(alpha=-1/3)", 2, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr},
      {"hermite_gauss(s=2)", 4, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, "hermite_gauss"}};
  const pardel_model m = order_two_model("spellings", discs, 4);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=0.7)"), &discs[0]);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha = 0.70)"), &discs[0]);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=14/20)"), &discs[0]);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=7e-1)"), &discs[0]);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=7/10)"), &discs[0]);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid"), &discs[1]);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=1.0)"), &discs[1]);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=-2/6)"), &discs[2]);
  EXPECT_EQ(pardel::find_discretization(m, "hermite_gauss"), &discs[3]);
  EXPECT_EQ(pardel::find_discretization(m, "hermite_gauss(s = 2)"), &discs[3]);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=0.71)"), nullptr);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=7/0)"), nullptr);
  EXPECT_EQ(pardel::find_discretization(m, "hermite_gauss(s=3)"), nullptr);
  EXPECT_EQ(pardel::find_discretization(m, "hermite_gauss ( )"), nullptr);
}

// The bare name is the model's word, not a rule of the runtime's: a model whose only trapezoid
// carries no bare name is not found by one, and a model may give it to any of its discretizations.
TEST(Api, ABareNameIsWhatTheModelSaysItIs) {
  const pardel_discretization discs[] = {
      {"trapezoid(alpha=1/2)", 2, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr},
      {"hermite_gauss(s=5)", 10, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, "hermite_gauss"}};
  const pardel_model m = order_two_model("own_defaults", discs, 2);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid"), nullptr);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=1)"), nullptr);
  EXPECT_EQ(pardel::find_discretization(m, "trapezoid(alpha=0.5)"), &discs[0]);
  EXPECT_EQ(pardel::find_discretization(m, "hermite_gauss"), &discs[1]);
  EXPECT_EQ(pardel::find_discretization(m, " hermite_gauss "), &discs[1]);
  EXPECT_EQ(pardel::find_discretization(m, "hermite_gauss(s=2)"), nullptr);
}

TEST(Api, SummaryReportsHowTheSolveEnded) {
  auto p = good_problem();
  auto traj = pardel::linear_guess(p);
  pardel::Options o;  // an absolute tolerance
  o.tol = 1e-10;
  o.method = pardel::Method::newton;
  const auto s = pardel::solve(p, o, traj);
  ASSERT_TRUE(s.converged());
  const std::string r = s.brief_report();
  EXPECT_NE(r.find("newton: converged"), std::string::npos) << r;
  EXPECT_NE(r.find("N = 10"), std::string::npos) << r;
  EXPECT_EQ(s.N, 10);
  EXPECT_GE(s.wall_seconds, 0.0);
  EXPECT_NEAR(s.final_time, p.t0 + p.T, 1e-15);
}

TEST(Api, HistoryStaysBoundedOnLongRuns) {
  auto p = good_problem();
  p.N = 400;
  auto traj = pardel::linear_guess(p);
  pardel::Options o;  // the seed's method at an absolute tolerance
  o.method = pardel::Method::jacobi_newton;
  o.tol = 1e-10;
  o.threads = 1;
  o.max_iterations = 20000;
  const auto s = pardel::solve(p, o, traj);
  EXPECT_EQ(s.iterations, 20000);
  EXPECT_LT(s.history.size(), 1400u);
  for (std::size_t i = 1; i < s.history.size(); ++i) EXPECT_GT(s.history[i].iteration, s.history[i - 1].iteration);
  EXPECT_EQ(s.history.back().iteration, 20000);
}

}  // namespace

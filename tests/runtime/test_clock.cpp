/**
 * @file test_clock.cpp
 * Time-dependent Lagrangians with a clock (hand-written forced particle L = x'^2/2 + t x, clock
 * h (1 + c x^2)): under free_final_time the node times are the prefix sums of the clock along
 * the returned trajectory and the travel time is their total; under fixed_total_time the steps
 * are proportional to the clock and sum to T. In both, convergence is declared with times
 * consistent with the final trajectory: the DEL residual at the returned times is below tol.
 * When the clock re-places the nodes under fixed_total_time, the nodes move along the trajectory
 * (detail::retime_nodes): checked against a known function, with its convergence order.
 * The bundled zermelo_tv (time-varying wind) is solved when the build has it.
 */
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <vector>

#include "engine.hpp"
#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

pardel::Problem forced_problem(pardel::ClockMode mode) {
  pardel::Problem p;
  p.model = &hand::forced;
  p.discretization = &hand::forced.discretizations[0];
  p.params = {0.5};
  p.t0 = 0.25;
  p.T = 1.0;
  p.N = 40;
  p.q0 = {0.0};
  p.qN = {1.0};
  p.clock = mode;
  return p;
}

double clock_value(const pardel::Problem& p, const pardel::Trajectory& tr, int k) {
  return p.model->clock(p.T / p.N, tr.t[k], tr.node(k), tr.node(k + 1), p.params.data());
}

TEST(Clock, FreeFinalTimeTimesArePrefixSumsOfTheClock) {
  for (auto method : {pardel::Method::newton, pardel::Method::jacobi_newton}) {
    const auto p = forced_problem(pardel::ClockMode::free_final_time);
    auto traj = pardel::linear_guess(p);
    pardel::Options opt;  // an absolute tolerance
    opt.tol = 1e-10;
    opt.method = method;
    opt.threads = 1;
    opt.clock_update_every = 5;
    const auto s = pardel::solve(p, opt, traj);
    ASSERT_TRUE(s.converged()) << s.brief_report();
    ASSERT_EQ(traj.t.size(), 41u);
    double t = p.t0;
    EXPECT_EQ(traj.t[0], p.t0);
    for (int k = 0; k < p.N; ++k) {
      t += clock_value(p, traj, k);
      EXPECT_NEAR(traj.t[k + 1], t, 1e-12) << "node " << k + 1;
    }
    EXPECT_EQ(s.final_time, traj.t.back());
    EXPECT_GT(s.final_time - p.t0, p.T);  // the clock is at least h on every interval
    EXPECT_LE(pardel::residual_norm(p, traj), 1e-10);
  }
}

TEST(Clock, FixedTotalTimeStepsFollowTheClockAndSumToT) {
  const auto p = forced_problem(pardel::ClockMode::fixed_total_time);
  auto traj = pardel::linear_guess(p);
  pardel::Options opt;  // an absolute tolerance
  opt.tol = 1e-10;
  opt.method = pardel::Method::newton;
  const auto s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  EXPECT_NEAR(traj.t.back(), p.t0 + p.T, 1e-14);
  EXPECT_NEAR(s.final_time, p.t0 + p.T, 1e-14);
  // The clock of this model does not read t: the steps are exactly proportional to it.
  double total = 0;
  for (int k = 0; k < p.N; ++k) total += clock_value(p, traj, k);
  for (int k = 0; k < p.N; ++k)
    EXPECT_NEAR(traj.t[k + 1] - traj.t[k], p.T * clock_value(p, traj, k) / total, 1e-12) << "interval " << k;
  EXPECT_LE(pardel::residual_norm(p, traj), 1e-10);
  // No error estimate: two grids' common nodes lie at other times under this clock.
  EXPECT_TRUE(std::isnan(s.error_estimate)) << s.error_note;
  EXPECT_NE(s.error_note.find("not estimated: under the fixed_total_time clock"), std::string::npos) << s.error_note;
  // The steps are not uniform: the solution moves away from x = 0.
  EXPECT_GT(traj.t[p.N] - traj.t[p.N - 1], 1.2 * (traj.t[1] - traj.t[0]));
}

TEST(Clock, TimesCheckedAtTheToleranceSettleWithoutDeformingThePath) {
  // No periodic update: the iteration first converges at uniform times, far from the clock's. The
  // check at the tolerance finds the residual at the clock's times above it, moves the nodes along
  // the trajectory instead of deforming it, and iterates on: the answer is the same coupled
  // solution (times from the clock of the returned nodes, DEL residual below tol) as with updates
  // every 5 iterations. The Jacobi methods' small steps reach the tolerance on the moved nodes at
  // once: a step is taken there before the times are checked again (checked at once, the nodes
  // only moved again, and the solve ended stalled).
  auto p = forced_problem(pardel::ClockMode::fixed_total_time);
  p.params = {4.0};  // a clock that varies by a factor 5 along the path
  std::vector<pardel::Trajectory> answers;
  for (auto method : {pardel::Method::newton, pardel::Method::jacobi, pardel::Method::jacobi_newton})
  for (int every : {5, 1000000}) {
    SCOPED_TRACE(pardel::to_string(method));
    auto traj = pardel::linear_guess(p);
    pardel::Options opt;
    opt.tol = 1e-10;
    opt.method = method;
    opt.max_iterations = 200000;
    opt.clock_update_every = every;
    const auto s = pardel::solve(p, opt, traj);
    ASSERT_TRUE(s.converged()) << "every " << every << ": " << s.brief_report();
    double total = 0;
    for (int k = 0; k < p.N; ++k) total += clock_value(p, traj, k);
    for (int k = 0; k < p.N; ++k)
      ASSERT_NEAR(traj.t[k + 1] - traj.t[k], p.T * clock_value(p, traj, k) / total, 1e-12) << "interval " << k;
    EXPECT_LE(pardel::residual_norm(p, traj), 1e-10);
    answers.push_back(traj);
  }
  EXPECT_GT(answers[0].t[p.N] - answers[0].t[p.N - 1], 2 * (answers[0].t[1] - answers[0].t[0]));
  for (std::size_t a = 1; a < answers.size(); ++a) {
    for (int k = 0; k <= p.N; ++k) {
      EXPECT_NEAR(answers[0].t[k], answers[a].t[k], 1e-8) << "answer " << a << ", node " << k;
      EXPECT_NEAR(answers[0].node(k)[0], answers[a].node(k)[0], 1e-8) << "answer " << a << ", node " << k;
    }
  }
}

/** Max error of retime_nodes on q(t) = sin(3t) + t^2 (and, with_derivative, q' stored beside q)
 *  from n uneven old intervals on [0, 1] to n other uneven ones. */
double retime_error(int n, bool with_derivative) {
  const int d = with_derivative ? 2 : 1;
  auto f = [](double t) { return std::sin(3 * t) + t * t; };
  auto df = [](double t) { return 3 * std::cos(3 * t) + 2 * t; };
  std::vector<double> t_old(n + 1), q_old((n + 1) * d), t_new(n + 1);
  for (int k = 0; k <= n; ++k) {
    const double s = static_cast<double>(k) / n;
    t_old[k] = s * s;                             // crowded at the start
    t_new[k] = std::sin(1.5707963267948966 * s);  // crowded at the end
    q_old[k * d] = f(t_old[k]);
    if (with_derivative) q_old[k * d + 1] = df(t_old[k]);
  }
  const pardel::detail::RetimeGrid old{t_old.data(), q_old.data(), 0, n, n, d, 1};
  std::vector<double> q_new((n - 1) * d);
  pardel::detail::retime_nodes(old, t_new.data() + 1, 1, n - 1, q_new.data());
  double err = 0;
  for (int k = 1; k < n; ++k) {
    err = std::max(err, std::fabs(q_new[(k - 1) * d] - f(t_new[k])));
    if (with_derivative) err = std::max(err, std::fabs(q_new[(k - 1) * d + 1] - df(t_new[k])));
  }
  return err;
}

TEST(Clock, RetimedNodesFollowTheTrajectoryInTime) {
  // Cubic Hermite: positions O(h^4) with exact slopes (order >= 2 models store q'), the stored
  // derivative O(h^3); central-difference slopes on an uneven grid give O(h^2) (order-1 models).
  const double e1 = retime_error(200, true), e2 = retime_error(400, true);
  EXPECT_LT(e1, 1e-5);
  EXPECT_GT(std::log2(e1 / e2), 2.7) << e1 << " " << e2;
  const double f1 = retime_error(200, false), f2 = retime_error(400, false);
  EXPECT_LT(f1, 1e-3);
  EXPECT_GT(std::log2(f1 / f2), 1.8) << f1 << " " << f2;
}

TEST(Clock, FixedTotalTimeUpdateKeepsTheSolvedTrajectory) {
  // Solved with the clock, then the nodes re-placed once more from the solution: the trajectory
  // hardly moves (it did move by O(1) of the step when nodes kept their values at new times).
  pardel::Problem problem = forced_problem(pardel::ClockMode::fixed_total_time);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.clock_update_every = 3;
  pardel::Trajectory tr = pardel::linear_guess(problem);
  const pardel::Summary s = pardel::solve(problem, options, tr);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  pardel::detail::Context ctx;
  std::string error;
  ASSERT_TRUE(pardel::detail::context_at(problem, tr, 1, ctx, &error)) << error;
  const std::vector<double> before = ctx.q;
  pardel::detail::update_times(ctx, pardel::detail::Positions::follow_times);
  double moved = 0, step = 0;
  for (std::size_t k = 0; k < before.size(); ++k) moved = std::max(moved, std::fabs(ctx.q[k] - before[k]));
  for (std::size_t k = 0; k + 1 < before.size(); ++k) step = std::max(step, std::fabs(before[k + 1] - before[k]));
  EXPECT_LT(moved, 0.05 * step);
}

TEST(Clock, WithoutClockTheForcedParticleMatchesItsExactDiscreteSolution) {
  // x'' = t: trapezoid DEL (x_{k+1} - 2x_k + x_{k-1})/h = h t_k, solved as a dense linear system.
  auto p = forced_problem(pardel::ClockMode::none);
  auto traj = pardel::linear_guess(p);
  pardel::Options opt;  // an absolute tolerance
  opt.method = pardel::Method::newton;
  opt.tol = 1e-13;
  ASSERT_TRUE(pardel::solve(p, opt, traj).converged());
  const int N = p.N;
  const double h = p.T / N;
  // The recurrence with x_0 = 0 and unknown slope s = x_1, fixed by x_N = 1 (linear in s).
  auto shoot = [&](double s) {
    double a = 0, b = s;
    for (int k = 1; k < N; ++k) {
      const double tk = p.t0 + k * h, c = 2 * b - a + h * h * tk;
      a = b;
      b = c;
    }
    return b;
  };
  const double s = (1 - shoot(0)) / (shoot(1) - shoot(0));
  double a = 0, b = s;
  EXPECT_NEAR(traj.node(1)[0], s, 1e-10);
  for (int k = 1; k < N; ++k) {
    const double tk = p.t0 + k * h, c = 2 * b - a + h * h * tk;
    a = b;
    b = c;
    EXPECT_NEAR(traj.node(k + 1)[0], b, 1e-10) << "node " << k + 1;
  }
}

TEST(Clock, ModelWithoutClockIsInvalidInput) {
  pardel::Problem p;
  p.model = &hand::harmonic;
  p.discretization = &hand::harmonic.discretizations[0];
  p.q0 = {0};
  p.qN = {1};
  p.clock = pardel::ClockMode::free_final_time;
  auto traj = pardel::linear_guess(p);
  const auto s = pardel::solve(p, pardel::Options{}, traj);
  EXPECT_EQ(s.termination, pardel::Termination::invalid_input);
  EXPECT_NE(s.message.find("clock"), std::string::npos) << s.message;
}

#ifdef PARDEL_HAVE_BUNDLED_MODELS
TEST(Clock, ZermeloWithTimeVaryingWind) {
  const pardel_model* m = pardel::find_model("zermelo_tv");
  if (!m) GTEST_SKIP() << "zermelo_tv is not bundled";
  pardel::Problem p;
  p.model = m;
  p.discretization = pardel::find_discretization(*m, "trapezoid");
  p.T = 1;
  p.N = 100;
  p.q0 = {0, 0};
  p.qN = {6, 2};
  p.clock = pardel::ClockMode::free_final_time;
  auto traj = pardel::linear_guess(p);
  pardel::Options opt;  // the default relative tolerance
  opt.method = pardel::Method::newton;
  opt.clock_update_every = 10;
  opt.max_iterations = 2000;
  const auto s = pardel::solve(p, opt, traj);
  ASSERT_TRUE(s.converged()) << s.brief_report();
  // L depends on t: each interval's end time is the fixed point of the clock integrated over it by
  // the discretization's quadrature, the time linear between its nodes.
  ASSERT_NE(p.discretization->travel, nullptr);
  for (int k = 0; k < p.N; ++k)
    EXPECT_NEAR(traj.t[k + 1] - traj.t[k],
                p.discretization->travel(p.T / p.N, traj.t[k], traj.t[k + 1], traj.node(k), traj.node(k + 1),
                                         m->param_defaults),
                1e-13)
        << k;
  EXPECT_EQ(s.final_time, traj.t[p.N]);
  // The returned trajectory is the converged one: its residual, recomputed here, is below the
  // tolerance the summary reports.
  EXPECT_LE(pardel::residual_norm(p, traj), s.tolerance);
}
#endif

}  // namespace

namespace {

// Travel kernels of one coordinate moving at unit speed, with a clock that depends on t; h is the
// parameter step. exp_travel: F = e^t by the trapezoid rule; root_travel: F = sqrt(1 - t), no
// travel time past t = 1.
double exp_travel(double h, double t0, double t1, const double*, const double*, const double*) {
  return h / 2 * (std::exp(t0) + std::exp(t1));
}
double root_travel(double h, double t0, double t1, const double*, const double*, const double*) {
  return t1 <= 1 ? h / 2 * (std::sqrt(1 - t0) + std::sqrt(1 - t1)) : std::nan("");
}

/** dt = travel(t0, t0 + dt) by plain fixed-point steps, the rule before the secant steps: NaN
 *  where 50 do not settle it to 4 ulps. */
double plain_fixed_point(pardel_action_kernel travel, double h, double t0, double dt) {
  for (int it = 0; it < 50 && std::isfinite(dt); ++it) {
    const double image = travel(h, t0, t0 + dt, nullptr, nullptr, nullptr);
    if (std::fabs(image - dt) <= 4 * std::numeric_limits<double>::epsilon() * std::max(std::fabs(t0), std::fabs(image)))
      return image;
    dt = image;
  }
  return std::nan("");
}

struct TravelGrid {
  pardel_model model = hand::forced;
  pardel_discretization disc = hand::forced.discretizations[0];
  pardel::detail::Grid grid;
  explicit TravelGrid(pardel_action_kernel travel) {
    model.time_dependent = 1;
    disc.travel = travel;
    grid.model = &model;
    grid.disc = &disc;
  }
};

}  // namespace

TEST(Clock, TheTravelTimesFixedPointSettlesWhereItsContractionIsSlow) {
  // F = e^t from t0 = 0 with h = 0.552: the fixed point dt = 1.125 has slope h e^dt / 2 = 0.85,
  // so plain steps need about 220 to settle from the left rule's h (more than they were allowed);
  // the secant steps settle it.
  TravelGrid g(exp_travel);
  const double q = 0, h = 0.552;
  EXPECT_TRUE(std::isnan(plain_fixed_point(exp_travel, h, 0.0, h)));
  const double dt = pardel::detail::free_time_step(g.grid, 0.0, &q, &q, h, h);
  ASSERT_TRUE(std::isfinite(dt));
  EXPECT_NEAR(dt, exp_travel(h, 0.0, dt, nullptr, nullptr, nullptr), 4e-16 * dt);
  EXPECT_NEAR(h * std::exp(dt) / 2, 0.85, 0.01);
}

TEST(Clock, TheTravelTimesFixedPointSettlesWherePlainStepsDo) {
  // Random intervals of two clocks (a fixed seed): wherever plain fixed-point steps settle, the
  // secant steps settle to the same time; where a secant step leaves the clock's domain (sqrt(1 - t)
  // past t = 1) or does not lower the residual, the plain step is taken instead.
  std::mt19937_64 random(20261129);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (pardel_action_kernel travel : {exp_travel, root_travel}) {
    TravelGrid g(travel);
    const double q = 0;
    int settled = 0;
    for (int i = 0; i < 2000; ++i) {
      const double t0 = unit(random), h = std::pow(10.0, -3 + 3.3 * unit(random));
      double guess = travel(h, t0, t0, nullptr, nullptr, nullptr);
      if (!(guess > 0)) guess = h;
      if (unit(random) < 0.5) guess *= 0.5 + 1.5 * unit(random);
      const double plain = plain_fixed_point(travel, h, t0, guess);
      if (!std::isfinite(plain)) continue;
      ++settled;
      const double dt = pardel::detail::free_time_step(g.grid, t0, &q, &q, h, guess);
      ASSERT_TRUE(std::isfinite(dt)) << "t0 = " << t0 << ", h = " << h << ", guess = " << guess;
      EXPECT_NEAR(dt, plain, 1e-12 * plain + 8 * std::numeric_limits<double>::epsilon() * t0);
    }
    EXPECT_GT(settled, 500);
  }
}

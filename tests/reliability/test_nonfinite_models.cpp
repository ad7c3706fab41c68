// Models whose kernels produce inf or NaN, solved by the runtime: a Lagrangian that divides by
// zero on the boundary, and one whose sqrt turns negative in the middle of the iteration (NaN
// mid-run). Every method must end with a status that says so (never "converged", never a
// crash), with a message, and hand back the last finite iterate.
#include <cmath>
#include <string>
#include <vector>

#include "model_workshop.hpp"
#include "pardel/pardel.hpp"

namespace {

using reliability::expect_compiled;
using reliability::Generated;

class NonFiniteModel : public reliability::ModelWorkshop {
 protected:
  const pardel_model* compile(const std::string& name, const std::string& text) {
    const Generated g = generate(name + ".lag", text);
    expect_compiled(g);
    return g.model;
  }

  /** Solves with `method` from the straight line and checks how the solve ended. */
  void expect_reported_failure(const pardel::Problem& problem, pardel::Method method, bool may_diverge) {
    pardel::Options options;  // an absolute tolerance
    options.tol = 1e-10;
    options.method = method;
    options.max_iterations = 2000;
    options.threads = 2;
    pardel::Trajectory trajectory = pardel::linear_guess(problem);
    const pardel::Summary summary = pardel::solve(problem, options, trajectory);
    SCOPED_TRACE(std::string("method ") + pardel::to_string(method) + ": " + summary.message);
    EXPECT_FALSE(summary.converged());
    const bool expected = summary.termination == pardel::Termination::non_finite ||
                          summary.termination == pardel::Termination::invalid_input ||
                          (may_diverge && summary.termination == pardel::Termination::diverged);
    EXPECT_TRUE(expected) << "termination " << pardel::to_string(summary.termination);
    EXPECT_FALSE(summary.message.empty());
    for (double value : trajectory.q) {
      ASSERT_TRUE(std::isfinite(value)) << "the returned trajectory holds a non-finite value";
    }
  }
};

TEST_F(NonFiniteModel, DivisionByZeroOnTheBoundaryIsReported) {
  // L = x'^2/2 + x'/x: with x = 0 at the start, D2 Ld of the first interval holds 1/(h x_0),
  // so the DEL residual at node 1 is infinite from the first evaluation on.
  const pardel_model* model = compile("inverse", "model inverse\ncoords x\nL = 1/2*x'^2 + x'/x\n");
  ASSERT_NE(model, nullptr);
  const pardel_discretization& disc = model->discretizations[0];
  const double q0[] = {0.0}, q1[] = {0.5};
  double Ld = 0, D1 = 0, D2 = 0;
  disc.grad(0.1, 0, 0.1, q0, q1, nullptr, &Ld, &D1, &D2);
  EXPECT_FALSE(std::isfinite(D2));

  pardel::Problem problem;
  problem.model = model;
  problem.discretization = &disc;
  problem.T = 1;
  problem.N = 16;
  problem.q0 = {0.0};
  problem.qN = {1.0};
  for (pardel::Method method : {pardel::Method::jacobi, pardel::Method::jacobi_newton, pardel::Method::newton,
                                pardel::Method::hybrid}) {
    expect_reported_failure(problem, method, false);
  }
}

TEST_F(NonFiniteModel, SqrtOfANegativeNumberMidRunIsReported) {
  // L = x'^2/2 + g x + sqrt(x): from x = 0.1 at both ends the path sags below x = 0 (x'' ~ g),
  // so sqrt(x) turns NaN after some iterations although the initial line is fine.
  const pardel_model* model =
      compile("sagging", "model sagging\ncoords x\nparam g = 10\nL = 1/2*x'^2 + g*x + sqrt(x)\n");
  ASSERT_NE(model, nullptr);
  pardel::Problem problem;
  problem.model = model;
  problem.discretization = &model->discretizations[0];
  problem.T = 2;
  problem.N = 32;
  problem.q0 = {0.1};
  problem.qN = {0.1};
  const pardel::Trajectory line = pardel::linear_guess(problem);
  EXPECT_TRUE(std::isfinite(pardel::residual_norm(problem, line))) << "the initial guess itself must be fine";
  for (pardel::Method method : {pardel::Method::jacobi, pardel::Method::jacobi_newton, pardel::Method::newton,
                                pardel::Method::hybrid}) {
    expect_reported_failure(problem, method, true);
  }
}

}  // namespace

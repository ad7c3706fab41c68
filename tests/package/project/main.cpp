// The package test's program: solves the projectile (projectile.lag) from (0, 0) at t = 0 to
// (4, 1) at t = 2 with g = 3.7 set by name, and checks the nodes and the boundary momenta against
// the exact path x = 2t, y = b t - g t^2/2 (b = (1 + 2g)/2), which the discretization reproduces.
// Also finds a bundled model through pardel::bundled_models. Exits 1 on any mismatch.
#include <cmath>
#include <cstdio>
#include <string>

#include "pardel/pardel.hpp"
#include "projectile.hpp"

namespace {

int failures = 0;

void expect_near(const char* what, double got, double want, double tol) {
  if (!(std::fabs(got - want) <= tol)) {
    std::fprintf(stderr, "mismatch: %s = %.17g, expected %.17g (tolerance %g)\n", what, got, want, tol);
    ++failures;
  }
}

}  // namespace

int main() {
  const double g = 3.7, T = 2;
  pardel::Problem problem;
  problem.model = &projectile_model;
  problem.discretization = pardel::find_discretization(projectile_model, "trapezoid");
  std::string error;
  if (!problem.discretization || !pardel::params_by_name(projectile_model, {{"g", g}}, &problem.params, &error)) {
    std::fprintf(stderr, "setup failed: %s\n", error.c_str());
    return 1;
  }
  problem.T = T;
  problem.N = 40;
  problem.q0 = {0, 0};
  problem.qN = {4, 1};

  pardel::Trajectory trajectory = pardel::linear_guess(problem);
  pardel::Options options;
  options.tol = 1e-12;
  const pardel::Summary summary = pardel::solve(problem, options, trajectory);
  std::printf("%s\n", summary.brief_report().c_str());
  if (!summary.converged()) return 1;

  const double b = (1 + 2 * g) / 2;
  for (int k = 0; k <= trajectory.N; ++k) {
    const double t = trajectory.t[k];
    expect_near("x(t_k)", trajectory.node(k)[0], 2 * t, 1e-9);
    expect_near("y(t_k)", trajectory.node(k)[1], b * t - g * t * t / 2, 1e-9);
  }
  const pardel::BoundaryMomenta momenta = pardel::boundary_momenta(problem, trajectory);
  if (momenta.p0.size() != 2 || momenta.pN.size() != 2) {
    std::fprintf(stderr, "no boundary momenta\n");
    return 1;
  }
  expect_near("p0_x", momenta.p0[0], 2, 1e-9);
  expect_near("p0_y", momenta.p0[1], b, 1e-9);
  expect_near("pN_x", momenta.pN[0], 2, 1e-9);
  expect_near("pN_y", momenta.pN[1], b - g * T, 1e-9);

  if (!pardel::find_model("harmonic")) {
    std::fprintf(stderr, "the bundled model harmonic is not found\n");
    ++failures;
  }
  if (failures) return 1;
  std::printf("projectile: nodes and boundary momenta match the exact path\n");
  return 0;
}

// solve_fuel_nav: the fuel-optimal navigation example of the seed paper, solved with pardel.
// The kernels of lagrangians/fuel_nav.lag are generated at build time (pardel_add_model) and
// linked into this program; it solves T = 30, N = 200, (0,0) -> (6,5) from a straight line,
// prints the certificate at the solution and writes the trajectory as "t x y" lines to stdout.
#include <cstdio>

#include "fuel_nav.hpp"
#include "pardel/pardel.hpp"

int main() {
  // The problem: the model, its trapezoid discretization, the time span and the boundary values.
  pardel::Problem problem;
  problem.model = &fuel_nav_model;
  problem.discretization = pardel::find_discretization(fuel_nav_model, "trapezoid");
  problem.T = 30;
  problem.N = 200;
  problem.q0 = {0, 0};
  problem.qN = {6, 5};

  // A straight line as the initial guess; Newton's method with the block LDL^T solver.
  pardel::Trajectory trajectory = pardel::linear_guess(problem);
  pardel::Options options;
  options.method = pardel::Method::newton;
  options.tol = 1e-10;

  pardel::Summary summary = pardel::solve(problem, options, trajectory);
  std::fprintf(stderr, "%s\n", summary.brief_report().c_str());
  if (!summary.converged()) return 1;

  // Why it converged: the convergence certificate at the solution.
  pardel::Certificate certificate = pardel::certify(problem, trajectory);
  std::fprintf(stderr, "%s", certificate.report().c_str());

  for (int k = 0; k <= trajectory.N; ++k)
    std::printf("%.10f %.10f %.10f\n", trajectory.t[k], trajectory.node(k)[0], trajectory.node(k)[1]);
  return 0;
}

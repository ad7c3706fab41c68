/**
 * @file distributed_timing.cpp
 * Time per iteration of the distributed solve (no assertions; not a test): fuel_nav from the
 * straight line at grid N for a fixed number of iterations, run alone or under mpirun.
 *   mpi_distributed_timing METHOD N ITERATIONS THREADS
 * prints one line on rank 0: ranks, threads, method, N, iterations, ms per iteration, residual.
 */
#include <cstdio>
#include <cstdlib>
#include <string>

#include "pardel/distributed.hpp"
#include "pardel/mpi_session.hpp"
#include "pardel/pardel.hpp"

int main(int argc, char** argv) {
  const pardel::mpi::Session session(&argc, &argv);
  if (argc != 5) {
    std::fprintf(stderr, "usage: %s METHOD N ITERATIONS THREADS\n", argv[0]);
    return 2;
  }
  pardel::Problem problem;
  problem.model = pardel::find_model("fuel_nav");
  if (!problem.model) return 2;
  problem.discretization = pardel::find_discretization(*problem.model, "trapezoid");
  problem.T = 30;
  problem.N = std::atoi(argv[2]);
  problem.q0 = {0, 0};
  problem.qN = {6, 5};
  pardel::Options options;
  if (!pardel::parse_method(argv[1], &options.method)) return 2;
  options.max_iterations = std::atol(argv[3]);
  options.threads = std::atoi(argv[4]);
  options.newton_shift = pardel::NewtonShift::difference;
  pardel::Trajectory trajectory = pardel::linear_guess(problem);
  const pardel::Summary s = pardel::mpi::solve_distributed(problem, options, trajectory);
  if (session.rank() == 0) {
    const auto& h = s.history;
    const double per = h.size() >= 2 ? (h.back().seconds - h.front().seconds) / (h.back().iteration - h.front().iteration) : 0;
    std::printf("ranks=%d threads=%d method=%s N=%d iterations=%ld ms_per_iteration=%.1f wall_s=%.2f residual=%.3g status=%s\n",
                session.size(), s.threads, pardel::to_string(s.method), s.N, s.iterations, per * 1e3, s.wall_seconds,
                s.residual, pardel::to_string(s.termination));
  }
  return 0;
}

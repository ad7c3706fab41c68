/**
 * @file momenta.cpp
 * The discrete boundary momenta of a trajectory: the discrete Legendre transforms at its ends,
 * p_0 = -D1 Ld(q_0, q_1) and p_N = D2 Ld(q_{N-1}, q_N), evaluated with the grad kernel.
 */
#include <string>

#include "pardel/pardel.hpp"

namespace pardel {

BoundaryMomenta boundary_momenta(const Problem& problem, const Trajectory& trajectory) {
  BoundaryMomenta momenta;
  std::string error;
  if (!validate(problem, trajectory, &error) || trajectory.N != problem.N || trajectory.N < 1 ||
      trajectory.t.size() != static_cast<std::size_t>(trajectory.N) + 1)
    return momenta;
  const pardel_model& model = *problem.model;
  std::vector<double> params = problem.params;
  if (params.empty() && model.nparams > 0) params.assign(model.param_defaults, model.param_defaults + model.nparams);
  const int N = trajectory.N;
  const std::size_t d = static_cast<std::size_t>(model.dim);
  // The step the kernels are called with: the span of the path parameter over N, except under the
  // Sundman clock, whose steps are the node-time differences (as in the solvers).
  auto step = [&](int k) {
    return problem.clock == ClockMode::fixed_total_time || !problem.times.empty() ? trajectory.t[k + 1] - trajectory.t[k]
                                                                                  : problem.T / N;
  };
  std::vector<double> D1(d), D2(d);
  double Ld = 0;
  problem.discretization->grad(step(0), trajectory.t[0], trajectory.t[1], trajectory.node(0), trajectory.node(1),
                               params.data(), &Ld, D1.data(), D2.data());
  momenta.p0.resize(d);
  for (std::size_t i = 0; i < d; ++i) momenta.p0[i] = -D1[i];
  problem.discretization->grad(step(N - 1), trajectory.t[N - 1], trajectory.t[N], trajectory.node(N - 1),
                               trajectory.node(N), params.data(), &Ld, D1.data(), D2.data());
  momenta.pN = D2;
  return momenta;
}

}  // namespace pardel

/**
 * @file ipopt_peer.hpp
 * The peer baseline: minimizes the same discrete action as pardel with IPOPT, using the same
 * generated kernels (gradient from D1/D2, exact Hessian from D11/D12/D22 in its sparse
 * block-tridiagonal pattern), so that benchmarks can compare pardel's solvers with a
 * general-purpose interior-point optimizer in one run.
 *
 * The unknowns are the free components of nodes 1..N-1: every component of an interior node,
 * except the coordinates pinned by knots (Problem::knots), which, like q_0 and q_N, are held
 * fixed. Node times are t_k = t0 + k*T/N (ClockMode::none only).
 */
#ifndef PARDEL_IPOPT_PEER_HPP
#define PARDEL_IPOPT_PEER_HPP

#include <string>

#include "pardel/pardel.hpp"

namespace pardel::peer {

struct IpoptOptions {
  double tol = 1e-10;          ///< on the infinity-norm of the DEL residual (IPOPT's tol and dual_inf_tol)
  int max_iterations = 3000;   ///< IPOPT's max_iter
  bool allow_acceptable = true;  ///< keep IPOPT's default "acceptable" stop (acceptable_tol 1e-6,
                                 ///< 15 iterations); false disables it
  int print_level = 0;         ///< IPOPT's print_level (0: silent)
  std::string linear_solver = "mumps";
  int threads = 1;             ///< threads for kernel evaluation (IPOPT's own work is sequential)
  /** Checks the options; on failure writes a message naming the option and value. */
  bool is_valid(std::string* error) const;
};

struct IpoptResult {
  bool ran = false;            ///< false when the input was rejected (message says why)
  std::string status;          ///< IPOPT's ApplicationReturnStatus, e.g. "Solve_Succeeded",
                               ///< "Solved_To_Acceptable_Level", "Maximum_Iterations_Exceeded"
  bool converged = false;      ///< the recomputed DEL residual is <= tol
  int iterations = 0;          ///< IPOPT iterations
  double wall_seconds = 0;     ///< time of the IPOPT solve alone (setup excluded)
  double residual = 0;         ///< infinity-norm DEL residual recomputed here at the final point
  double action = 0;           ///< discrete action at the final point
  long variables = 0;          ///< number of unknowns passed to IPOPT
  long hessian_nonzeros = 0;   ///< lower-triangle non-zeros of the Hessian
  std::string message;
  std::string brief_report() const;
};

/**
 * Minimizes the discrete action of `problem` with IPOPT starting from `trajectory` (N+1 nodes of
 * problem.model->dim values; the boundary nodes are taken from problem.q0 and problem.qN).
 * On return `trajectory` holds IPOPT's final point. Never throws on bad input: returns ran=false.
 */
IpoptResult solve_ipopt(const Problem& problem, const IpoptOptions& options, Trajectory& trajectory);

/** The straight-line initial guess from q0 to qN with node times t0 + k*T/N. */
Trajectory straight_line(const Problem& problem);

/** The infinity-norm of the DEL residual over free components, and the discrete action. */
double del_residual(const Problem& problem, const Trajectory& trajectory);
double action_of(const Problem& problem, const Trajectory& trajectory);

}  // namespace pardel::peer

#endif  // PARDEL_IPOPT_PEER_HPP

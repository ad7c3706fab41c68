/**
 * @file cuda.hpp
 * Solves on an NVIDIA GPU (target pardel::cuda, built with PARDEL_WITH_CUDA): batches of
 * independent problems by the seed's Jacobi and Jacobi-Newton sweeps, one node per device thread,
 * or by Newton, one problem per device thread; every problem's stopping rules on the device
 * (docs/gpu.md).
 */
#ifndef PARDEL_CUDA_HPP
#define PARDEL_CUDA_HPP

#include <string>
#include <vector>

#include "pardel/pardel.hpp"

namespace pardel {

/** Makes Options::device = Device::cuda work in solve() and solve_batch() of this program (they
 *  call solve_batch_cuda with the default CudaSettings); the command line and the Python module
 *  call it when pardel was built with CUDA. */
void enable_cuda();

/** Whether a CUDA device can run solves here; false with the reason (no driver, no device). */
bool cuda_device_available(std::string* why = nullptr);

/** Whether the device build has the kernels of this model and discretization (the models compiled
 *  for the device: PARDEL_DEVICE_MODELS); false with a message naming those it has. */
bool cuda_supports(const pardel_model& model, const pardel_discretization& discretization, std::string* why = nullptr);

/** Where the time of a device batch went (seconds, measured with device events). */
struct CudaBatchTimes {
  double upload = 0;    ///< guesses, grid and params to the device
  double sweeps = 0;    ///< the sweeps (or Newton iterations) and the decisions, to the last problem's stop
  double download = 0;  ///< the iterates and the per-problem records back
  double host = 0;      ///< the host's part after the download: actions and point assessments
  long sweeps_run = 0;  ///< sweeps launched (the last problem's iterations + 1); Newton: the most iterations of a problem
};

/** How often the host looks at the device (no other host round trip happens between sweeps). */
struct CudaSettings {
  int check_every = 32;  ///< sweeps (Newton: iterations) between the host's reads of the count of running problems
  bool assess = true;    ///< assess the point of each converged problem on the host (assess_point)
  /// thread blocks of 128 threads per problem in a sweep (0: as many as fill the device once with
  /// the whole batch, at most one per 128 nodes); the threads of a problem take its nodes in turn
  int blocks_per_problem = 0;
};

/**
 * solve_batch (pardel.hpp) on the CUDA device: the same problems, options and entries, for the
 * methods jacobi and jacobi_newton (Options::damping, newton_substeps, rtol, tol, max_iterations,
 * divergence_factor and keep_going, polled every check_every sweeps), and newton and automatic
 * (Newton on one grid, globalized by a shift and step halving on the action: rtol, tol,
 * max_iterations, divergence_factor, keep_going), on one grid: no knots, no clock, no
 * refine_start_N; the error estimate and iterative refinement are not run (the entry says so).
 * With the sweeps every problem's iterates, statuses and iteration counts are those of solve()
 * with the same options, up to the rounding of blocks larger than 2x2; with Newton its converged
 * answer is solve()'s where both reach the same minimum (iteration counts differ: the CPU's
 * Newton globalizes by a trust region). Refused as a whole (BatchSummary::refusal, nothing
 * allocated) for other options, a model the device build lacks, no device, or memory the device
 * does not have free.
 */
BatchSummary solve_batch_cuda(const Problem& base, const Options& options, const std::vector<BatchProblem>& problems,
                              const CudaSettings& settings = CudaSettings{}, CudaBatchTimes* times = nullptr);

}  // namespace pardel

#endif  // PARDEL_CUDA_HPP

// Memory estimate of a solve, from the runtime's own block types, and the machine's memory (see
// pardel/memory.hpp).
#include "pardel/memory.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "block_tridiagonal.hpp"
#include "cyclic_reduction.hpp"
#include "engine.hpp"
#include "methods.hpp"

namespace pardel {
namespace {

/** Heap bytes of one malloc(b) in glibc: an 8-byte header, rounded up to 16, at least 32. */
double heap(double b) { return std::max(32.0, 16.0 * std::ceil((b + 8) / 16.0)); }

/** Bytes of one block of the runtime's block-tridiagonal algebra at dim d: the Eigen types of
 *  BlockTridiagonal<D> for the block sizes the runtime specializes (detail::dispatch_dim), where a
 *  block is inline; at other dims D is Eigen::Dynamic and every block's coefficients are a
 *  separate heap allocation besides the object itself. */
struct BlockBytes {
  bool fixed_size = false;
  double mat = 0;  ///< a d x d matrix
  double vec = 0;  ///< a vector of d values
  double llt = 0;  ///< Eigen::LLT of a block
  double lu = 0;   ///< Eigen::PartialPivLU of a block: the matrix, two index vectors, the norm and flags
};

BlockBytes block_bytes(int d) {
  return detail::dispatch_dim(d, [d](auto size) {
    constexpr int D = decltype(size)::value;
    using Mat = typename detail::BlockTridiagonal<D>::Mat;
    using Vec = typename detail::BlockTridiagonal<D>::Vec;
    const bool fixed = D != Eigen::Dynamic;
    const double coefficients = fixed ? 0 : heap(8.0 * d * d);
    BlockBytes b;
    b.fixed_size = fixed;
    b.mat = sizeof(Mat) + coefficients;
    b.vec = sizeof(Vec) + (fixed ? 0 : heap(8.0 * d));
    b.llt = sizeof(Eigen::LLT<Mat>) + coefficients;
    b.lu = sizeof(Eigen::PartialPivLU<Mat>) + (fixed ? 0 : coefficients + 2 * heap(4.0 * d));
    return b;
  });
}

}  // namespace

/** BlockTridiagonal<D>: diag, off, W, y and the pivots' factors for N-1 blocks (resize), and with
 *  `cyclic` the cyclic-reduction levels (N-1, (N-1)/2, ..., 1 rows: about 2(N-1) in all, each of
 *  three d x d blocks and two vectors of d). */
double detail::block_tridiagonal_bytes(double N, int d, bool cyclic) {
  const BlockBytes b = block_bytes(d);
  const double n = std::max(N - 1, 0.0);
  const double factors = b.fixed_size ? b.mat : b.llt;
  const double levels = cyclic ? 8.0 * static_cast<double>(cyclic_reduction::values(static_cast<long>(n), d)) : 0;
  return n * (3 * b.mat + b.vec + factors) + levels;
}

double detail::newton_bytes(double N, int d, bool cyclic) {
  // The trial evaluation's second set of interval arrays (trust_region.hpp) is not counted: the
  // finest level of a nested solve, where the peak is, seldom refuses a step and then never takes
  // it; a level that does take it needs about 150 bytes a node more (d = 2), which the tests of
  // this estimate find within its band (tests/reliability/test_memory_estimate.cpp).
  return 4 * std::max(N - 1, 0.0) * d * 8 + block_tridiagonal_bytes(N, d, cyclic);
}

namespace {

/** detail::Context at N (engine.cpp setup_context). */
double context_bytes(double N, int d) {
  const double n1 = N + 1;
  return n1 * 8 * 2                // t, hk
         + n1 * d + n1 * 4         // is_free, free_count
         + n1 * d * 8 * 3          // q, q_next, res
         + N * 8                   // Ld
         + N * d * 8 * 2           // D1, D2
         + N * d * d * 8 * 3       // D11, D12, D22
         + n1 * 8;                 // node_scratch
}

double trajectory_bytes(double N, int d) { return (N + 1) * (d + 1) * 8.0; }

std::string read_file(const char* path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/** The value in kB of "KEY:   123 kB" in a /proc file, in bytes; -1 if absent. */
double proc_kb(const std::string& text, const std::string& key) {
  const std::size_t at = text.find(key + ":");
  if (at == std::string::npos) return -1;
  std::istringstream in(text.substr(at + key.size() + 1));
  double kb = -1;
  in >> kb;
  return kb >= 0 ? kb * 1024 : -1;
}

}  // namespace

MemoryEstimate estimate_solve_memory(const Problem& problem, const Options& options, bool certificate) {
  const double N = problem.N;
  const pardel_model& model = *problem.model;
  const int d = model.dim;
  MemoryEstimate e;
  // The initial guess, solve()'s working copy, and with refinement the resampled level.
  const bool levels = options.refine_start_N > 0 || options.method == Method::automatic;
  const double trajectories = (levels ? 3 : 2) * trajectory_bytes(N, d);
  const bool cyclic = options.linear_solver == LinearSolver::cyclic_reduction;
  const detail::MethodRow* method = detail::method_row(options.method);
  e.solve = context_bytes(N, d) + (method ? method->bytes(N, d, cyclic) : 0) + trajectories;
  // Context::q_old: the iterate before a re-placement of the nodes (engine.cpp update_times).
  if (problem.clock == ClockMode::fixed_total_time) e.solve += (N + 1) * d * 8;
  // Context::t_kept, hk_kept: the node times and steps before a convergence check's clock update.
  if (problem.clock != ClockMode::none) e.solve += (2 * N + 1) * 8;
  // Newton on nested levels: the eigenvector estimates of the last two coarse levels (two vectors
  // each, at N/4 and N/16 of the nodes), which start the assessment's Lanczos runs.
  if (levels && method && method->whole_system_newton) e.solve += 2 * (N / 4 + N / 16) * d * 8;
  // The point assessment (assessment.cpp): the solve's context and trajectories, the Hessian and
  // the four vectors of its Lanczos iterations.
  const double n = std::max(N - 1, 0.0);
  e.assessment = context_bytes(N, d) + trajectories + detail::block_tridiagonal_bytes(N, d, false) + 4 * n * d * 8;
  // certify(): its own context, the Hessian, Cholesky pivots, four vectors of the spectral-radius
  // iteration, interval verdicts, and (Hessian not positive definite) LU factors of the diagonal
  // blocks in a vector that grows by doubling (up to 3n of them while it moves).
  if (certificate) {
    e.certificate = trajectory_bytes(N, d) + context_bytes(N, d) + detail::block_tridiagonal_bytes(N, d, false) +
                    n * block_bytes(d).llt + 3 * n * block_bytes(d).lu + 4 * n * d * 8 + N * 32;
  }
  // trajectory.csv: about 24 characters per number, a std::string that grows by doubling.
  const int columns = 2 + d + (model.order == 1 ? model.ncoords : 0);
  e.output = trajectory_bytes(N, d) + 2 * (N + 1) * (24.0 * columns + 8);
  e.peak = std::max({e.solve, e.assessment, e.certificate, e.output});
  e.largest = e.peak == e.solve        ? "solve"
              : e.peak == e.assessment ? "assessment"
              : e.peak == e.certificate ? "certificate"
                                        : "output";
  return e;
}

MachineMemory machine_memory(double needed) {
  constexpr double kReadAvailableFrom = 16e6;  // bytes
  MachineMemory m;
  if (needed >= kReadAvailableFrom) m.available = proc_kb(read_file("/proc/meminfo"), "MemAvailable");
  rlimit limit{};
  if (::getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY) {
    m.address_limit = static_cast<double>(limit.rlim_cur);
    m.address_used = proc_kb(read_file("/proc/self/status"), "VmSize");  // only weighed against a limit
  }
  return m;
}

std::string format_bytes(double bytes) {
  char text[64];
  if (bytes >= 1e9) std::snprintf(text, sizeof text, "%.2f GB", bytes / 1e9);
  else if (bytes >= 1e6) std::snprintf(text, sizeof text, "%.0f MB", bytes / 1e6);
  else std::snprintf(text, sizeof text, "%.0f kB", bytes / 1e3);
  return text;
}

std::string memory_refusal(const Problem& problem, const Options& options, const MemoryEstimate& estimate,
                           const MachineMemory& machine) {
  const std::string need = "grid.N = " + std::to_string(problem.N) + " needs an estimated " +
                           format_bytes(estimate.peak) + " (method " + to_string(options.method) +
                           ", linear solver " + to_string(options.linear_solver) + ", model dim " +
                           std::to_string(problem.model->dim) + "; largest phase: " + estimate.largest + ")";
  if (machine.available >= 0 && estimate.peak > machine.available) {
    return need + "; this machine has " + format_bytes(machine.available) +
           " available (MemAvailable in /proc/meminfo); lower grid.N";
  }
  if (machine.address_limit >= 0) {
    // Every thread reserves a stack and a malloc arena of address space (not memory).
    const int threads = std::max(1, options.threads > 0 ? options.threads
                                                        : static_cast<int>(::sysconf(_SC_NPROCESSORS_ONLN)));
    const double reserved = threads * 72e6;
    const double used = std::max(machine.address_used, 0.0);
    if (used + reserved + estimate.peak > machine.address_limit) {
      return need + "; the address space of this process is limited to " + format_bytes(machine.address_limit) +
             " (RLIMIT_AS, `ulimit -v`), of which " + format_bytes(used) + " are in use and about " +
             format_bytes(reserved) + " are reserved by " + std::to_string(threads) +
             " thread(s); lower grid.N, run fewer threads (solver.threads) or raise the limit";
    }
  }
  return "";
}

}  // namespace pardel

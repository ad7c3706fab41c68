/**
 * @file memory.hpp
 * The memory a solve needs, estimated before anything of size N is allocated, and what the
 * machine can give (MemAvailable of /proc/meminfo, RLIMIT_AS), so that a problem too large for the
 * machine is refused with a message naming grid.N (the scene key of Problem::N) instead of ending
 * in std::bad_alloc or the kernel's OOM killer.
 *
 * The estimate adds up the arrays the runtime allocates (the solve context, the method's
 * scratch, the block-tridiagonal factors of Newton and hybrid, the certificate computed after the
 * solve, the trajectory written as CSV text) phase by phase, from the sizes of the runtime's own
 * types, and takes the largest phase; it was checked against the peak resident set size of real
 * solves (tests/reliability/test_memory_estimate.cpp).
 */
#ifndef PARDEL_MEMORY_HPP
#define PARDEL_MEMORY_HPP

#include <string>

#include "pardel/pardel.hpp"

namespace pardel {

/** Bytes a solve needs at its peak, beyond the process's start-up footprint. */
struct MemoryEstimate {
  double solve = 0;        ///< while iterating: context, method scratch, input and working trajectories
  double assessment = 0;   ///< while assessing the returned point (after the method's memory is freed)
  double certificate = 0;  ///< while certifying the result (only when asked for: `certificate`; else 0)
  double output = 0;       ///< while writing the trajectory as CSV text (trajectory.csv)
  double peak = 0;         ///< the largest of the four
  std::string largest;     ///< which phase is the peak: "solve", "assessment", "certificate" or "output"
};

/** Estimates the memory of a solve of `problem` (its N and model) with `options` (method, linear
 *  solver, grid refinement), with the seed's certificate when `certificate` is true. */
MemoryEstimate estimate_solve_memory(const Problem& problem, const Options& options, bool certificate = false);

/** What the machine offers; a value < 0 means unknown or unlimited. */
struct MachineMemory {
  double available = -1;      ///< MemAvailable of /proc/meminfo, bytes
  double address_limit = -1;  ///< RLIMIT_AS (soft), bytes
  double address_used = -1;   ///< VmSize of this process now (/proc/self/status), bytes; read only under a limit
};

/** The machine's memory for an estimate of `needed` bytes: MemAvailable is read only where
 *  `needed` is at least 16 MB (reading /proc/meminfo took 15 us, 7 % of a small solve's call, and
 *  a machine without 16 MB to spare fails before the solve), the address-space limit always. */
MachineMemory machine_memory(double needed);

/**
 * "" when the estimate fits the machine, else the reason, naming grid.N, the estimate and what
 * the machine has, e.g. "grid.N = 100000000 needs an estimated 38.4 GB (method newton, dim 4, ...);
 * this machine has 19.9 GB available (MemAvailable)".
 */
std::string memory_refusal(const Problem& problem, const Options& options, const MemoryEstimate& estimate,
                           const MachineMemory& machine);

/** Bytes as "123 MB" / "4.56 GB" (decimal units). */
std::string format_bytes(double bytes);

}  // namespace pardel

#endif  // PARDEL_MEMORY_HPP

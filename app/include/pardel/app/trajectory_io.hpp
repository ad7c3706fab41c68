/**
 * @file trajectory_io.hpp
 * Trajectory files: trajectory.csv (k, t, the coordinates and their stored derivatives) written
 * and read back, and atomic file writes (temporary file, then rename).
 */
#ifndef PARDEL_APP_TRAJECTORY_IO_HPP
#define PARDEL_APP_TRAJECTORY_IO_HPP

#include <string>
#include <vector>

#include "pardel/app/scene.hpp"
#include "pardel/pardel.hpp"

namespace pardel::app {

/** Names of the stored components of a node: the coordinates, then x', y', ..., up to order-1 primes. */
std::vector<std::string> state_column_names(const pardel_model& model);

/**
 * The velocity column of coordinate i at node k of an order-1 model's trajectory: the derivative
 * at t_k of the quadratic in t through the three nearest nodes (k-1, k, k+1 inside; 0, 1, 2 at the
 * start; N-2, N-1, N at the end), second-order accurate at every node, the end points included;
 * on a uniform grid the central difference (q_{k+1} - q_{k-1}) / (2h) inside and
 * (-3 q_0 + 4 q_1 - q_2) / (2h), (3 q_N - 4 q_{N-1} + q_{N-2}) / (2h) at the ends. The slope of
 * the one interval when N = 1; NaN when two of the node times coincide.
 */
double node_velocity(const Trajectory& trajectory, int k, int i);

/**
 * trajectory.csv: header "k,t,<state columns>" and, for order-1 models, the velocity columns
 * x', y', ... (node_velocity), which are not part of the stored state. Numbers are printed with
 * 17 significant digits.
 */
std::string trajectory_csv(const pardel_model& model, const Trajectory& trajectory);

/**
 * Reads a trajectory.csv written by trajectory_csv (columns found by name; extra columns ignored).
 * The node index and the time are the first columns named k and t; a coordinate named k or t is
 * the second column of that name, and any other name given twice is refused ("duplicate column").
 * The file must be a regular file of at most pardel::FileLimits::trajectory bytes (512 MiB, checked
 * before reading; pardel/regular_file.hpp) with lines of at most 1 MiB; it is read line by line.
 * Throws std::runtime_error "PATH:LINE:COL: error: ..." on a missing or duplicate column, a
 * non-numeric cell, a wrong row count or k out of sequence, "PATH: error: ..." when the file
 * cannot be read (a folder, a FIFO, a device, too large).
 */
Trajectory read_trajectory_csv(const std::string& path, const pardel_model& model);

/** Why `trajectory` is not a path of `scene`'s boundary-value problem, in words naming the node,
 *  the component and the scene's key ("node 0 has x = 5, the scene's boundary.q0 has x = 0"), or ""
 *  when it is one, and then the scene's problem fitted to it for a check at it (`pardel check
 *  --trajectory`, pardel.check): problem.N its N and, where the scene's solve chooses its grid
 *  (grid.accuracy, no clock), problem.times its node times. Values agree to 1e-9 of the larger, or
 *  of 1. Checked: the first and last nodes against boundary.q0 and boundary.qN; the node times
 *  against the scene's grid at N = trajectory.N (pardel::grid_times), or, in a scene with
 *  grid.accuracy or under a clock, t0 first, increasing, t0 + T last except under free_final_time;
 *  each knot on an interior node with the knot's coordinates there. */
std::string fit_to_path(Scene& scene, const Trajectory& trajectory);

/** Writes `content` to `path` through a temporary file in the same folder and a rename, so that
 *  readers never see a half-written file. Throws std::runtime_error naming the path on failure. */
void write_file_atomic(const std::string& path, const std::string& content);

/** The first half of write_file_atomic: writes `content` to PATH.tmp.PID beside `path`, flushed to
 *  disk, and returns that name. Throws std::runtime_error naming the file on failure. */
std::string write_temporary(const std::string& path, const std::string& content);

/** The second half: renames the temporary file over `path` (removing it on failure, and throwing
 *  std::runtime_error naming `path`). */
void rename_into_place(const std::string& temporary, const std::string& path);

/** Removes the temporary files PATH.tmp.PID of `path` whose process no longer runs (left behind by
 *  a write that was killed, e.g. with SIGKILL, before its rename). */
void remove_stale_temporaries(const std::string& path);

/** Formats a double with 17 significant digits ("nan", "inf" and "-inf" when not finite). */
std::string format_double(double value);

}  // namespace pardel::app

#endif  // PARDEL_APP_TRAJECTORY_IO_HPP

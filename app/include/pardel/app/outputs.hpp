/**
 * @file outputs.hpp
 * What a solve of a scene writes besides the trajectory: convergence.csv, summary.json (status,
 * numbers, the example's physical cost and the convergence certificate), the cost itself and the
 * report `pardel solve` prints.
 */
#ifndef PARDEL_APP_OUTPUTS_HPP
#define PARDEL_APP_OUTPUTS_HPP

#include <nlohmann/json.hpp>
#include <string>

#include "pardel/pardel.hpp"
#include "pardel/app/scene.hpp"

namespace pardel::app {

/** The physical cost a scene's example minimizes, as reported in summary.json. */
struct PhysicalCost {
  std::string name;        ///< the model's declared name ("fuel", "travel_time"), or "action"
  double value = 0;
  std::string definition;  ///< how the value was computed
};

/**
 * The cost the model declares (`cost NAME = action|clock` in its .lag, carried in pardel_model):
 * the discrete action under NAME, or the travel time, i.e. the summed clock (or
 * Summary::final_time - t0 under free_final_time). A model with a clock and no declaration
 * reports the travel time under free_final_time; every other model the discrete action ("action").
 */
PhysicalCost physical_cost(const Scene& scene, const Summary& summary, const Trajectory& trajectory);

/** The clock summed over the intervals (requires model.clock): each interval's integral of it by
 *  the discretization's quadrature (pardel_discretization::travel), or the seed's left rule (the
 *  model's clock kernel) where the discretization has none (a model compiled without it). */
double summed_clock(const Problem& problem, const Trajectory& trajectory);

/** convergence.csv: iteration,N,residual,action,seconds — one row per history record. */
std::string convergence_csv(const Summary& summary);

/** Every field of the certificate; at most `max_violations` violations are listed
 *  (violations_total gives their number). */
nlohmann::ordered_json certificate_json(const Certificate& certificate, std::size_t max_violations = 100);

/** The solve's point assessment (minimum, saddle, degenerate; inertia; smallest eigenvalues). */
nlohmann::ordered_json point_json(const PointAssessment& point);

/** The discrete boundary momenta of a trajectory on its own grid (coarser than the problem's when a
 *  solve stopped on a coarse level); both empty when it is not a valid trajectory of the problem. */
BoundaryMomenta momenta_on_trajectory_grid(const Problem& problem, const Trajectory& trajectory);

/** The discrete boundary momenta of a trajectory on its own grid, as summary.json's
 *  "boundary_momenta": {"p0": -D1 Ld(q_0, q_1), "pN": D2 Ld(q_{N-1}, q_N)} (dim values each, the
 *  order of the state columns); null when the trajectory is not a valid one of the problem. */
nlohmann::ordered_json boundary_momenta_json(const Problem& problem, const Trajectory& trajectory);

/** summary.json for one solve (the certificate only when it was computed: free_components > 0). */
nlohmann::ordered_json summary_json(const Scene& scene, const Summary& summary, const Trajectory& trajectory,
                                    const Certificate& certificate, const std::string& model_source);

/** The absolute path of a model's .lag source (as recorded, inside the project, or relative to the
 *  working folder), or "" when it cannot be found. */
std::string model_source_path(const pardel_model& model);

/** The .lag a scene's model comes from, for summary.json: the scene's `model` path made absolute,
 *  else the bundled model's source (model_source_path). */
std::string scene_model_source(const Scene& scene);

/**
 * Makes the output folder `dir` with its missing parents. Throws std::runtime_error
 * "DIR: cannot create output folder: WHAT", where WHAT names the part of the path at fault when one
 * is: a symbolic link to nothing (dangling) or into a loop, a link to something other than a
 * folder, a file, FIFO, device or socket where a folder should be; else the system's reason
 * (permission denied, name too long, ...).
 */
void create_output_folder(const std::string& dir);

/** Why the outputs of a solve of `scene` would not fit on the file system of `out_dir` (its first
 *  existing ancestor), or "": trajectory.csv takes about 16 bytes a value or more ((N + 1) rows of
 *  the state's columns with k and t), refused where that alone exceeds the free space, so that a
 *  long solve is not run for outputs that cannot be written. "" where the free space is unknown
 *  (a file system of no capacity, such as /proc) or the ancestor is no folder (whose creation
 *  fails with its own reason). */
std::string disk_refusal(const Scene& scene, const std::string& out_dir);
/** The same against `available` bytes free. */
std::string disk_refusal(const Scene& scene, const std::string& out_dir, double available);

/** What a finished solve wrote. */
struct SolveOutputs {
  bool have_trajectory = false;  ///< the returned trajectory lies on the problem's grid
  Certificate certificate;       ///< at that trajectory (empty without one, or unless asked for)
};

/**
 * With `full_certificate`, certifies the returned trajectory (when there is one: a solve refused as
 * invalid input returns none; the summary's point assessment is always there), and writes summary.json (with the fields of `extra` appended), trajectory.csv and
 * convergence.csv into out_dir as a set: written to temporary files first, then renamed into place
 * under a lock on the folder, summary.json removed first and renamed last, so that a summary.json
 * always describes the trajectory.csv and convergence.csv beside it.
 */
SolveOutputs write_solve_outputs(const Scene& scene, const Summary& summary, const Trajectory& trajectory,
                                 const std::string& out_dir, const nlohmann::ordered_json& extra = {},
                                 bool full_certificate = false);

/** The report `pardel solve` prints on stdout: the brief report, `extra_line` when not empty, the
 *  physical cost, the point assessment, the certificate's verdicts (when computed) and the output
 *  folder. */
void print_solve_report(const Scene& scene, const Summary& summary, const Trajectory& trajectory,
                        const Certificate& certificate, const std::string& out_dir,
                        const std::string& extra_line = "");

}  // namespace pardel::app

#endif  // PARDEL_APP_OUTPUTS_HPP

/**
 * @file sweep.hpp
 * Multi-start sweeps (`pardel sweep SWEEP.toml`): a sweep file names a base scene and what varies
 * (listed and random polyline guesses, scene keys over lists or ranges); every variant is solved,
 * the converged ones are grouped into distinct local solutions (by action and by the distance
 * between trajectories) and ranked by the physical cost. Parsing is strict like scene.hpp:
 * unknown keys, wrong types and bad values raise SceneError "FILE:LINE:COL: error: ...".
 * Under mpirun the variants are spread over the ranks (run_variants_over_ranks); a build without
 * MPI is one rank of one.
 */
#ifndef PARDEL_APP_SWEEP_HPP
#define PARDEL_APP_SWEEP_HPP

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "pardel/pardel.hpp"
#include "pardel/app/scene.hpp"

namespace pardel::app {

/** One scene key that varies: its values as TOML text (as given to --set), in sweep order. */
struct VaryAxis {
  std::string key;                  ///< dotted scene key, e.g. params.s or grid.N
  std::vector<std::string> values;  ///< TOML text of each value
  std::string where;                ///< FILE:LINE:COL of the [[vary]] entry
};

/** Random polyline guesses: `count` polylines with `interior_points` vertices between the ends. */
struct RandomGuessSpec {
  int count = 0;
  int interior_points = 2;
  std::uint64_t seed = 0;
  bool in_box = false;          ///< vertices uniform in [box_min, box_max] (else around the straight line)
  std::vector<double> box_min;  ///< ncoords values
  std::vector<double> box_max;  ///< ncoords values
  double spread = 0;            ///< around the line: each coordinate offset uniform in [-spread, spread]
};

/** When two converged variants of one configuration count as the same local solution:
 *  |action_a - action_b| <= action_tol * max(1, |action_a|) and the largest difference of any
 *  stored component at any node <= distance_tol. */
struct GroupingOptions {
  double action_tol = 1e-8;
  double distance_tol = 1e-4;
};

/** A parsed sweep file with every configuration's scene loaded and checked. */
struct Sweep {
  std::string path;          ///< the sweep file
  std::string scene_path;    ///< the base scene (resolved against the sweep file's folder)
  std::vector<std::string> sets;  ///< overrides of the base scene for every variant (file, then command line)
  /** Per override, where the sweep file holds it ("FILE:LINE:COL: error: set[i]"); empty for the
   *  command line's. */
  std::vector<std::string> set_origins;
  std::vector<VaryAxis> axes;
  std::vector<Scene> configurations;  ///< one per combination of axis values (last axis fastest)
  std::vector<std::vector<std::string>> configuration_values;  ///< the axis values of each configuration
  std::vector<std::vector<std::vector<double>>> listed_guesses;  ///< polylines (ncoords values per vertex)
  RandomGuessSpec random;
  /** interior_points*ncoords numbers in [0, 1) per random guess, guess after guess (one array:
   *  no allocation per guess, however many there are) */
  std::vector<double> random_unit;
  GroupingOptions grouping;
  std::string output_dir;  ///< [output].dir resolved against the working folder, or ""
  bool plot = true;        ///< [output].plot
  /** Refuse a variant whose memory estimate (pardel/memory.hpp) exceeds what the machine has,
   *  before anything of its size is allocated (status "error", the reason in its message). */
  bool memory_check = true;

  /** Guesses per configuration: listed + random, or 1 (the scene's own guess) when none is given. */
  int guesses_per_configuration() const;
  int variant_count() const;
};

/** What one variant solves: configuration `configuration`, guess `guess`. */
struct Variant {
  int id = 0;
  int configuration = 0;
  int guess = 0;
  std::string guess_label;  ///< "scene", "listed 0", "random 3"
  std::vector<std::vector<double>> points;  ///< polyline vertices, empty for the scene's own guess
};

/**
 * Parses sweep text. `source_name` names it in messages and relative paths resolve against its
 * folder; `command_line_sets` ("key=value") override the base scene after the file's `set` list
 * and before the varied keys. Every configuration's scene is loaded here, so a bad value of a
 * varied key is reported before anything is solved.
 */
Sweep parse_sweep(std::string_view text, const std::string& source_name,
                  const std::vector<std::string>& command_line_sets, const ModelResolver& resolve,
                  const std::vector<std::string>& model_names = {});

/** Reads and parses a sweep file; a missing file is a SceneError too. */
Sweep load_sweep(const std::string& path, const std::vector<std::string>& command_line_sets,
                 const ModelResolver& resolve, const std::vector<std::string>& model_names = {});

/** Variant `id` (0 <= id < variant_count()): configuration id / guesses, guess id % guesses. */
Variant make_variant(const Sweep& sweep, int id);

/** The result of one variant. The trajectory is kept only when the solve converged. */
struct VariantResult {
  int id = 0;
  int configuration = 0;
  std::string status;   ///< to_string(Termination), or "error" when the solve threw
  std::string message;
  long iterations = 0;
  double residual = std::numeric_limits<double>::quiet_NaN();  ///< NaN where not computed (not solved)
  double action = std::numeric_limits<double>::quiet_NaN();
  double cost = std::numeric_limits<double>::quiet_NaN();      ///< physical_cost(...).value
  double seconds = 0;
  bool hessian_positive_definite = false;
  long inertia_negative = 0;
  long inertia_zero = 0;
  bool certificate_valid = false;  ///< the certificate was computed (no error)
  Trajectory trajectory;
  /** When >= 0: the id of the earlier converged variant (a solution's representative) that this
   *  one was found to reach while the sweep ran; its trajectory was then released (see
   *  run_variants_over_ranks), and group_solutions puts it in that representative's solution. */
  int same_as = -1;
  bool converged() const { return status == "converged"; }
};

/** Solves one variant with `threads` OpenMP threads (0: all cores; negative: the scene's
 *  solver.threads, as when --threads is not given); never throws
 *  for a numerical failure (the status says it), and reports an exception as status "error".
 *  A variant whose memory estimate exceeds what the machine has (Sweep::memory_check) is not
 *  started: status "error", the message names grid.N, the estimate and the machine's memory.
 *  When `stop` (may be null) becomes true the solve is interrupted (status "interrupted"); a
 *  variant that finds it already true is not started. */
VariantResult solve_variant(const Sweep& sweep, const Variant& variant, int threads,
                            const std::atomic<bool>* stop = nullptr);

/** A distinct local solution: the converged variants of one configuration that reach it. */
struct Solution {
  int id = 0;             ///< 1-based, in order of (configuration, cost, first variant)
  int configuration = 0;
  int rank = 0;           ///< 1 = lowest cost within its configuration
  int first_variant = 0;  ///< the representative: the first variant (in variant order) that reached it
  std::vector<int> variants;
  double cost = 0, action = 0, residual = 0;  ///< the representative's
};

/** The certificate's verdict on a variant: "minimum", "saddle (K negative)", "degenerate (K zero)",
 *  "unknown" when the certificate could not be computed. */
std::string certificate_verdict(const VariantResult& result);

/** Whether two converged results are the same local solution under `options`. */
bool same_solution(const VariantResult& a, const VariantResult& b, const GroupingOptions& options);

/** The largest difference of any stored component at any node (infinity when N or dim differ). */
double trajectory_distance(const Trajectory& a, const Trajectory& b);

/**
 * Groups converged results (given in variant order) into distinct solutions: each result joins
 * the first earlier solution of its configuration whose representative it matches, else starts a
 * new one. Solutions are returned sorted by (configuration, cost, first variant) with ids and
 * ranks set; `solution_of` (when given) receives, per entry of `results`, its solution id or 0.
 */
std::vector<Solution> group_solutions(const std::vector<VariantResult>& results, const GroupingOptions& options,
                                      std::vector<int>* solution_of = nullptr);

/** Summary numbers written to sweep.json besides the tables. */
struct SweepRunInfo {
  int ranks = 1;
  int threads = 0;
  double wall_seconds = 0;
};

/**
 * Writes solutions.csv, variants.csv, sweep.json and solution_<id>.csv (the trajectory of each
 * solution's representative) into `out_dir`, each atomically. `results` holds the variants that
 * were started, in variant order (after an interruption the others are counted in sweep.json as
 * "not_started"). The files of an earlier sweep in `out_dir` are removed first, sweep.json (the
 * index) before the others and written last, so that whenever sweep.json exists every
 * solution_<id>.csv, solutions.csv and variants.csv beside it belong to it; sweep.png is removed
 * too (the plot step draws the new one).
 */
void write_sweep_outputs(const Sweep& sweep, const std::vector<VariantResult>& results,
                         const std::vector<Solution>& solutions, const std::vector<int>& solution_of,
                         const SweepRunInfo& info, const std::string& out_dir);

/** The dictionary of sweep.json: the sweep, model, cost, configurations, run info, tolerances, the
 *  converged count, failures by status, every solution and the best. */
nlohmann::ordered_json sweep_json(const Sweep& sweep, const std::vector<VariantResult>& results,
                                  const std::vector<Solution>& solutions, const SweepRunInfo& info);

/** solutions.csv text: solution,configuration,rank,cost,action,residual,variants,first_variant,certificate. */
std::string solutions_csv(const std::vector<VariantResult>& results, const std::vector<Solution>& solutions);

/**
 * Solves the variants of `sweep` assigned to this rank (id % size == rank) and gathers the
 * results on rank 0 in variant order (other ranks get an empty vector). `threads` and `stop` as
 * in solve_variant; once `stop` is true no further variant is started, and the variants not
 * started have no result (rank 0 gets fewer than sweep.variant_count()). `on_done` (may be empty)
 * is called on each rank after each of its variants. Nothing is allocated per variant up front.
 * With `keep_trajectories` false (one rank only), a converged variant that reaches the solution
 * of an earlier one (the comparisons of group_solutions, in the same order) keeps no trajectory
 * and records that variant in `same_as`, so that memory grows with the distinct solutions, not
 * with the converged variants.
 */
std::vector<VariantResult> run_variants_over_ranks(const Sweep& sweep, int threads, int rank, int size,
                                                   const std::function<void(int done, int mine)>& on_done = {},
                                                   const std::atomic<bool>* stop = nullptr,
                                                   bool keep_trajectories = true);

/** The report `pardel sweep` prints on stdout: the counts, one line per solution (cost, action,
 *  residual, variants, certificate), the best solution and the output folder. */
void print_sweep_report(const Sweep& sweep, const std::vector<VariantResult>& results,
                        const std::vector<Solution>& solutions, const SweepRunInfo& info, const std::string& out_dir);

}  // namespace pardel::app

#endif  // PARDEL_APP_SWEEP_HPP

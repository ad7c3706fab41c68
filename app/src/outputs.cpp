// convergence.csv, summary.json, the physical cost and the report of a solve (see outputs.hpp).
#include "pardel/app/outputs.hpp"

#include <fmt/format.h>
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <utility>
#include <vector>

#include "pardel/app/trajectory_io.hpp"
#include "pardel/memory.hpp"

namespace pardel::app {
namespace {

/** An exclusive flock(2) on a folder for the lifetime of the object (best effort: where the
 *  folder cannot be opened or the file system has no locks, nothing is locked). */
class FolderLock {
 public:
  explicit FolderLock(const std::string& dir) : fd_(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC)) {
    if (fd_ < 0) return;
    while (::flock(fd_, LOCK_EX) != 0 && errno == EINTR) {
    }
  }
  ~FolderLock() {
    if (fd_ >= 0) ::close(fd_);
  }
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  int fd_;
};

/** The discretization's travel kernel (the clock integrated by its quadrature), or null: the seed's
 *  left rule then. */
pardel_action_kernel travel_kernel(const Problem& problem) {
  return problem.discretization ? problem.discretization->travel : nullptr;
}

/** Interval k's share of the summed clock: its travel kernel where the discretization has one,
 *  else the left rule. */
double clock_share(const Problem& problem, const Trajectory& trajectory, int k) {
  const pardel_action_kernel travel = travel_kernel(problem);
  const double h = problem.T / trajectory.N;
  return travel ? travel(h, trajectory.t[k], trajectory.t[k + 1], trajectory.node(k), trajectory.node(k + 1),
                         problem.params.data())
                : problem.model->clock(h, trajectory.t[k], trajectory.node(k), trajectory.node(k + 1),
                                       problem.params.data());
}

}  // namespace

double summed_clock(const Problem& problem, const Trajectory& trajectory) {
  double total = 0;
  for (int k = 0; k < trajectory.N; ++k) total += clock_share(problem, trajectory, k);
  return total;
}

PhysicalCost physical_cost(const Scene& scene, const Summary& summary, const Trajectory& trajectory) {
  const Problem& problem = scene.problem;
  const pardel_model& model = *scene.model;
  // What the model declares (`cost NAME = action|clock` in its .lag) decides; a clock that only
  // places the nodes (a Sundman step) leaves the declared action cost alone.
  const bool declared = model.cost_name != nullptr;
  if (declared && model.cost_kind == PARDEL_COST_ACTION) {
    return {model.cost_name, summary.action, "the discrete action, which the model declares its cost"};
  }
  // Time-reparametrized models: the clock is dt/ds, its sum the travel time.
  if (model.clock && problem.clock == ClockMode::free_final_time) {
    return {declared ? model.cost_name : "travel_time", summary.final_time - problem.t0,
            travel_kernel(problem)
                ? "t_N - t_0, the node times being the prefix sums of the model's clock integrated over each "
                  "interval by the discretization's quadrature (free final time)"
                : "t_N - t_0, the node times being the prefix sums of the model's clock by the left rule (free final "
                  "time)"};
  }
  if (declared && model.cost_kind == PARDEL_COST_CLOCK && model.clock) {
    const double value = summed_clock(problem, trajectory);
    std::string definition = travel_kernel(problem)
                                 ? "sum over intervals of the clock F integrated over each by the discretization's "
                                   "quadrature"
                                 : "sum over intervals of h * clock(t_k, q_k, (q_{k+1} - q_k)/h) (left rule of the "
                                   "clock F)";
    for (int k = 0; k < trajectory.N && !std::isfinite(value); ++k)  // name the first interval at fault
      if (!std::isfinite(clock_share(problem, trajectory, k))) {
        definition += fmt::format("; not finite: the clock's share of interval {} (t = {:.6g} to {:.6g}) is not a "
                                  "number, the model's clock being undefined or infinite on the path there",
                                  k, trajectory.t[k], trajectory.t[k + 1]);
        break;
      }
    return {model.cost_name, value, definition};
  }
  return {"action", summary.action, "the discrete action"};
}

std::string convergence_csv(const Summary& summary) {
  std::string out = "iteration,N,residual,action,seconds\n";
  for (const auto& record : summary.history) {
    out += std::to_string(record.iteration) + "," + std::to_string(record.N) + "," + format_double(record.residual) +
           "," + format_double(record.action) + "," + format_double(record.seconds) + "\n";
  }
  return out;
}

nlohmann::ordered_json certificate_json(const Certificate& c, std::size_t max_violations) {
  nlohmann::ordered_json j;
  j["theorem_holds"] = c.theorem_holds;
  j["all_intervals_psd"] = c.all_intervals_psd;
  j["all_A_pd"] = c.all_A_pd;
  j["all_B_pd"] = c.all_B_pd;
  j["hessian_positive_definite"] = c.hessian_positive_definite;
  j["inertia_positive"] = c.inertia_positive;
  j["inertia_negative"] = c.inertia_negative;
  j["inertia_zero"] = c.inertia_zero;
  j["jacobi_spectral_radius"] = c.jacobi_spectral_radius;
  j["jacobi_one_minus_rho"] = c.jacobi_one_minus_rho;
  j["jacobi_one_minus_rho_roundoff"] = c.jacobi_one_minus_rho_roundoff;
  j["spectral_radius_resolved"] = c.spectral_radius_resolved;
  j["spectral_radius_converged"] = c.spectral_radius_converged;
  j["expected_iterations"] = c.expected_iterations;
  // Every violating interval (Certificate::violations lists at most the first 100 of them).
  j["violations_total"] = std::max<long>(c.intervals_violating, static_cast<long>(c.violations.size()));
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < c.violations.size() && i < max_violations; ++i) {
    const auto& v = c.violations[i];
    list.push_back({{"k", v.k},
                    {"hessian_psd", v.hessian_psd},
                    {"A_pd", v.A_pd},
                    {"B_pd", v.B_pd},
                    {"min_eig_hessian", v.min_eig_hessian},
                    {"min_eig_A", v.min_eig_A},
                    {"min_eig_B", v.min_eig_B}});
  }
  j["violations"] = list;
  j["free_components"] = c.free_components;
  j["intervals_violating"] = c.intervals_violating;
  j["residual"] = c.residual;
  j["tol"] = c.tol;
  j["error"] = c.error;
  return j;
}

nlohmann::ordered_json point_json(const PointAssessment& p) {
  nlohmann::ordered_json j;
  j["kind"] = to_string(p.kind);
  j["inertia"] = {{"positive", p.positive}, {"negative", p.negative}, {"zero", p.zero}};
  j["lambda_min"] = p.lambda_min;
  j["lambda_next"] = p.lambda_next;
  j["lambda_max_bound"] = p.lambda_max;
  j["lambda_settled"] = p.lambda_settled;
  j["nearly_degenerate"] = p.nearly_degenerate;
  j["soft_motion"] = p.soft_motion;
  j["note"] = p.note;
  return j;
}

BoundaryMomenta momenta_on_trajectory_grid(const Problem& problem, const Trajectory& trajectory) {
  Problem on_grid = problem;  // the trajectory's grid: a solve interrupted on a coarse level has fewer nodes
  on_grid.N = trajectory.N;
  return boundary_momenta(on_grid, trajectory);
}

nlohmann::ordered_json boundary_momenta_json(const Problem& problem, const Trajectory& trajectory) {
  const BoundaryMomenta momenta = momenta_on_trajectory_grid(problem, trajectory);
  if (momenta.p0.empty()) return nullptr;
  return {{"p0", momenta.p0}, {"pN", momenta.pN}};
}

nlohmann::ordered_json summary_json(const Scene& scene, const Summary& summary, const Trajectory& trajectory,
                                    const Certificate& certificate, const std::string& model_source) {
  const Problem& problem = scene.problem;
  const PhysicalCost cost = physical_cost(scene, summary, trajectory);
  nlohmann::ordered_json j;
  j["status"] = to_string(summary.termination);
  j["message"] = summary.message;
  j["iterations"] = summary.iterations;
  j["residual"] = summary.residual;
  j["action"] = summary.action;
  j["cost"] = {{"name", cost.name}, {"value", cost.value}, {"definition", cost.definition}};
  j["final_time"] = summary.final_time;
  j["wall_seconds"] = summary.wall_seconds;
  j["assessment_seconds"] = summary.assessment_seconds;
  j["method"] = to_string(summary.method);
  j["N"] = summary.N;
  j["threads"] = summary.threads;
  const char* wait = std::getenv("OMP_WAIT_POLICY");
  j["openmp_wait_policy"] = wait != nullptr ? wait : "default";
  j["model"] = scene.model->name;
  j["model_source"] = model_source;
  j["discretization"] = scene.discretization;
  j["clock"] = to_string(problem.clock);
  nlohmann::ordered_json params = nlohmann::ordered_json::object();
  for (int i = 0; i < scene.model->nparams; ++i) params[scene.model->param_names[i]] = problem.params[i];
  j["params"] = params;
  nlohmann::ordered_json knots = nlohmann::ordered_json::array();
  for (const auto& knot : problem.knots) knots.push_back({{"t", knot.t}, {"q", knot.q}});
  j["knots"] = knots;
  j["t0"] = problem.t0;
  j["T"] = problem.T;
  j["tol"] = scene.options.tol;
  j["rtol"] = scene.options.rtol;
  j["tolerance"] = summary.tolerance;
  j["scene"] = scene.path;
  j["point"] = point_json(summary.point);
  if (std::isfinite(summary.error_estimate))
    j["error_estimate"] = summary.error_estimate;
  else
    j["error_estimate"] = nullptr;  // not estimated
  nlohmann::ordered_json by_coordinate = nlohmann::ordered_json::object();
  for (std::size_t i = 0; i < summary.error_by_coordinate.size() && i < static_cast<std::size_t>(scene.model->ncoords); ++i)
    by_coordinate[scene.model->coords[i]] = summary.error_by_coordinate[i];
  j["error"] = {{"by_coordinate", by_coordinate},
                {"coarse_N", summary.error_coarse_N},
                {"seconds", summary.error_seconds},
                {"extrapolated", summary.extrapolated},
                {"observed_order", std::isfinite(summary.error_observed_order)
                                       ? nlohmann::ordered_json(summary.error_observed_order)
                                       : nlohmann::ordered_json()},
                {"reliable", summary.error_reliable},
                {"time", std::isfinite(summary.error_time_estimate) ? nlohmann::ordered_json(summary.error_time_estimate)
                                                                    : nlohmann::ordered_json()},
                {"solve", std::isfinite(summary.solve_error) ? nlohmann::ordered_json(summary.solve_error)
                                                             : nlohmann::ordered_json()},
                {"note", summary.error_note}};
  j["grid"] = {{"accuracy", scene.options.accuracy > 0 ? nlohmann::ordered_json(scene.options.accuracy) : nlohmann::ordered_json()},
               {"sizes", summary.grid_sizes},
               {"note", summary.grid_note}};
  j["refinement"] = {{"steps", summary.refinement_steps},
                     {"largest_change", summary.refinement_change},
                     {"note", summary.refinement_note}};
  j["boundary_momenta"] = boundary_momenta_json(problem, trajectory);
  if (certificate.free_components > 0 || !certificate.error.empty()) j["certificate"] = certificate_json(certificate);
  return j;
}

std::string model_source_path(const pardel_model& model) {
  namespace fs = std::filesystem;
  if (!model.source || !*model.source) return "";
  const fs::path source(model.source);
  std::error_code ec;
  if (source.is_absolute()) return fs::exists(source, ec) ? source.string() : "";
  const fs::path in_project = fs::path(PARDEL_SOURCE_DIR) / source;
  if (fs::exists(in_project, ec)) return in_project.lexically_normal().string();
  if (fs::exists(source, ec)) return fs::absolute(source, ec).lexically_normal().string();
  return "";
}

std::string scene_model_source(const Scene& scene) {
  if (scene.model_path.empty()) return model_source_path(*scene.model);
  std::error_code ec;
  return std::filesystem::absolute(scene.model_path, ec).lexically_normal().string();
}

namespace {

const char* kind_of(std::filesystem::file_type type) {
  switch (type) {
    case std::filesystem::file_type::regular: return "a file";
    case std::filesystem::file_type::character: return "a character device";
    case std::filesystem::file_type::block: return "a block device";
    case std::filesystem::file_type::fifo: return "a FIFO";
    case std::filesystem::file_type::socket: return "a socket";
    default: return "something other than a folder";
  }
}

/** The first part of `dir` (from its start) that exists and is not a folder or a link to one,
 *  described; "" when every existing part is a folder. */
std::string why_not_a_folder(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  fs::path prefix;
  for (const fs::path& part : dir) {
    prefix /= part;
    std::error_code ec;
    const fs::file_status own = fs::symlink_status(prefix, ec);
    if (ec || !fs::exists(own)) return "";
    if (fs::is_symlink(own)) {
      const std::string target = fs::read_symlink(prefix, ec).string();
      const fs::file_status pointed = fs::status(prefix, ec);
      if (ec == std::errc::too_many_symbolic_link_levels)
        return fmt::format("{} is a symbolic link to '{}' in a loop of links", prefix.string(), target);
      if (!fs::exists(pointed))
        return fmt::format("{} is a symbolic link to '{}', which does not exist", prefix.string(), target);
      if (!fs::is_directory(pointed))
        return fmt::format("{} is a symbolic link to '{}', which is {}, not a folder", prefix.string(), target,
                           kind_of(pointed.type()));
    } else if (!fs::is_directory(own)) {
      return fmt::format("{} is {}, not a folder", prefix.string(), kind_of(own.type()));
    }
  }
  return "";
}

}  // namespace

void create_output_folder(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (!ec) return;
  const std::string why = why_not_a_folder(dir);
  throw std::runtime_error(fmt::format("{}: cannot create output folder: {}", dir, why.empty() ? ec.message() : why));
}

std::string disk_refusal(const Scene& scene, const std::string& out_dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path at = fs::absolute(out_dir.empty() ? fs::path(".") : fs::path(out_dir), ec);
  if (ec) return "";
  while (!fs::exists(at, ec) && at.has_parent_path() && at.parent_path() != at) at = at.parent_path();
  // Where no folder can be made (a file in the way) the folder's creation says why; a file system
  // of no capacity (/proc) reports no free space that means anything.
  if (!fs::is_directory(at, ec)) return "";
  const fs::space_info space = fs::space(at, ec);
  if (ec || space.capacity == 0 || space.available == static_cast<std::uintmax_t>(-1)) return "";
  return disk_refusal(scene, out_dir, static_cast<double>(space.available));
}

std::string disk_refusal(const Scene& scene, const std::string& out_dir, double available) {
  if (!scene.model) return "";
  const double columns = static_cast<double>(state_column_names(*scene.model).size() + 2);
  const double rows = static_cast<double>(scene.problem.N) + 1;
  const double need = 16.0 * rows * columns;
  if (need <= available) return "";
  return fmt::format("{}: trajectory.csv alone needs about {} ({:.0f} rows of {:.0f} columns) and the file system "
                     "there has {} free; free space, write elsewhere (--out) or lower grid.N",
                     out_dir, format_bytes(need), rows, columns, format_bytes(available));
}

SolveOutputs write_solve_outputs(const Scene& scene, const Summary& summary, const Trajectory& trajectory,
                                 const std::string& out_dir, const nlohmann::ordered_json& extra,
                                 bool full_certificate) {
  namespace fs = std::filesystem;
  SolveOutputs outputs;
  // The certificate needs a trajectory on the problem's grid.
  outputs.have_trajectory = trajectory.N >= 2 && static_cast<int>(trajectory.t.size()) == trajectory.N + 1;
  if (outputs.have_trajectory && full_certificate) {
    Problem final_problem = scene.problem;
    final_problem.N = trajectory.N;
    outputs.certificate = certify(final_problem, trajectory, scene.options.threads);
  }
  nlohmann::ordered_json summary_doc =
      summary_json(scene, summary, trajectory, outputs.certificate, scene_model_source(scene));
  for (const auto& [key, value] : extra.items()) summary_doc[key] = value;

  // The three files are committed as a set. Each is first written to a temporary file beside it
  // (a failure there leaves the previous outputs as they were); then, holding a lock on the folder
  // so that two solves into one folder commit one after the other, summary.json is removed, the
  // others are renamed into place and summary.json comes last. Whenever summary.json exists, the
  // trajectory.csv and convergence.csv beside it are the ones it describes, even if the process
  // is killed between two renames.
  const std::string summary_path = (fs::path(out_dir) / "summary.json").string();
  const std::string trajectory_path = (fs::path(out_dir) / "trajectory.csv").string();
  const std::string convergence_path = (fs::path(out_dir) / "convergence.csv").string();
  for (const std::string& path : {summary_path, trajectory_path, convergence_path}) remove_stale_temporaries(path);
  std::vector<std::pair<std::string, std::string>> staged;  // temporary file, final name
  auto discard = [&staged](std::size_t from) {
    for (std::size_t i = from; i < staged.size(); ++i) std::remove(staged[i].first.c_str());
  };
  try {
    if (outputs.have_trajectory)
      staged.emplace_back(write_temporary(trajectory_path, trajectory_csv(*scene.model, trajectory)), trajectory_path);
    staged.emplace_back(write_temporary(convergence_path, convergence_csv(summary)), convergence_path);
    // Paths that are not UTF-8 are written with U+FFFD for their invalid bytes: valid JSON, the solve kept.
    const auto replace = nlohmann::ordered_json::error_handler_t::replace;
    staged.emplace_back(write_temporary(summary_path, summary_doc.dump(2, ' ', false, replace) + "\n"), summary_path);
  } catch (...) {
    discard(0);
    throw;
  }
  const FolderLock lock(out_dir);
  if (::unlink(summary_path.c_str()) != 0 && errno != ENOENT) {
    const int err = errno;
    discard(0);
    throw std::runtime_error(fmt::format("{}: cannot replace: {}", summary_path, std::strerror(err)));
  }
  // Without a trajectory, an older trajectory.csv would not belong to the new summary.
  if (!outputs.have_trajectory) ::unlink(trajectory_path.c_str());
  // Nor would the pictures of an earlier solve: the plot step draws this one's, or none if it fails.
  for (const char* png : {"trajectory.png", "convergence.png"}) ::unlink((fs::path(out_dir) / png).c_str());
  for (std::size_t i = 0; i < staged.size(); ++i) {
    try {
      rename_into_place(staged[i].first, staged[i].second);
    } catch (...) {
      discard(i + 1);
      throw;
    }
  }
  return outputs;
}

void print_solve_report(const Scene& scene, const Summary& summary, const Trajectory& trajectory,
                        const Certificate& certificate, const std::string& out_dir, const std::string& extra_line) {
  const PhysicalCost cost = physical_cost(scene, summary, trajectory);
  std::cout << summary.brief_report() << "\n";
  if (!extra_line.empty()) std::cout << extra_line << "\n";
  std::cout << fmt::format("{} = {} ({})\n", cost.name, format_double(cost.value), cost.definition);
  if (summary.point.kind != PointKind::unknown)
    std::cout << fmt::format("point: {} (inertia +{} -{} 0:{}): {}\n", to_string(summary.point.kind),
                             summary.point.positive, summary.point.negative, summary.point.zero, summary.point.note);
  if (certificate.free_components > 0)
    std::cout << fmt::format("certificate: theorem {}, Hessian {} (inertia +{} -{} 0:{}), Jacobi spectral radius {}\n",
                             certificate.theorem_holds ? "holds" : "does not hold",
                             certificate.hessian_positive_definite ? "positive definite" : "not positive definite",
                             certificate.inertia_positive, certificate.inertia_negative, certificate.inertia_zero,
                             certificate.spectral_radius_resolved
                                 ? format_double(certificate.jacobi_spectral_radius)
                                 : std::string("1 to within round-off"));
  std::cout << "output: " << out_dir << "\n";
}

}  // namespace pardel::app

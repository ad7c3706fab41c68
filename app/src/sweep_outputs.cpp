// The outputs of `pardel sweep`: solution_<id>.csv, solutions.csv, variants.csv (streamed) and
// sweep.json, written atomically after an earlier sweep's files are removed, and the printed report
// (see sweep.hpp for the contract).
#include "pardel/app/sweep.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include <unistd.h>

#include "pardel/app/outputs.hpp"
#include "pardel/app/trajectory_io.hpp"

namespace pardel::app {

namespace fs = std::filesystem;

namespace {

/** A CSV cell: quoted when it holds a comma, a quote or a newline. */
std::string csv_cell(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string points_text(const std::vector<std::vector<double>>& points) {
  std::string out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    out += i ? ";" : "";
    for (std::size_t j = 0; j < points[i].size(); ++j) out += (j ? " " : "") + fmt::format("{}", points[i][j]);
  }
  return out;
}

const VariantResult* find_result(const std::vector<VariantResult>& results, int id) {
  if (id >= 0 && id < static_cast<int>(results.size()) && results[id].id == id) return &results[id];
  // In variant order, with the variants not started (after an interruption) left out.
  const auto it = std::lower_bound(results.begin(), results.end(), id,
                                   [](const VariantResult& r, int value) { return r.id < value; });
  if (it != results.end() && it->id == id) return &*it;
  for (const auto& r : results) {
    if (r.id == id) return &r;
  }
  return nullptr;
}

/** Writes the text that `append(out)` produces, chunk by chunk, to a temporary file beside `path`
 *  and renames it into place (memory stays bounded however many rows there are). */
void write_streamed_atomic(const std::string& path, const std::function<bool(std::string& out)>& append) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw std::runtime_error(fmt::format("{}: cannot write: {}", tmp, std::strerror(errno)));
  std::string chunk;
  bool ok = true;
  for (bool more = true; more && ok;) {
    chunk.clear();
    while ((more = append(chunk)) && chunk.size() < (1u << 20)) {
    }
    ok = std::fwrite(chunk.data(), 1, chunk.size(), f) == chunk.size();
  }
  ok = ok && std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  const int err = errno;
  if (std::fclose(f) != 0 || !ok) {
    std::remove(tmp.c_str());
    throw std::runtime_error(fmt::format("{}: cannot write: {}", tmp, std::strerror(err)));
  }
  rename_into_place(tmp, path);
}

/** solution_<digits>.csv, the trajectory files of a sweep. */
bool is_solution_file(const std::string& name) {
  constexpr std::string_view prefix = "solution_", suffix = ".csv";
  if (name.size() <= prefix.size() + suffix.size() || name.compare(0, prefix.size(), prefix) != 0 ||
      name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
    return false;
  const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  return digits.find_first_not_of("0123456789") == std::string::npos;
}

}  // namespace

std::string solutions_csv(const std::vector<VariantResult>& results, const std::vector<Solution>& solutions) {
  std::string out = "solution,configuration,rank,cost,action,residual,variants,first_variant,certificate\n";
  for (const auto& s : solutions) {
    const VariantResult* r = find_result(results, s.first_variant);
    out += fmt::format("{},{},{},{},{},{},{},{},{}\n", s.id, s.configuration, s.rank, format_double(s.cost),
                       format_double(s.action), format_double(s.residual), s.variants.size(), s.first_variant,
                       csv_cell(r ? certificate_verdict(*r) : "unknown"));
  }
  return out;
}

void write_sweep_outputs(const Sweep& sweep, const std::vector<VariantResult>& results,
                         const std::vector<Solution>& solutions, const std::vector<int>& solution_of,
                         const SweepRunInfo& info, const std::string& out_dir) {
  create_output_folder(out_dir);
  const fs::path dir(out_dir);
  const std::string index_path = (dir / "sweep.json").string();
  // Paths that are not UTF-8 are written with U+FFFD for their invalid bytes (valid JSON, never thrown).
  const std::string index =
      sweep_json(sweep, results, solutions, info).dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) +
      "\n";

  // An earlier sweep's files go first, its index (sweep.json) before the rest: an interrupted or
  // smaller sweep must not leave solution_<id>.csv files (or a picture) that look like its own.
  // Whenever sweep.json exists, the files beside it are the ones it lists.
  for (const char* name : {"sweep.json", "solutions.csv", "variants.csv", "sweep.png"}) {
    remove_stale_temporaries((dir / name).string());
    if (::unlink((dir / name).c_str()) != 0 && errno != ENOENT)
      throw std::runtime_error(fmt::format("{}: cannot remove the earlier sweep's file: {}", (dir / name).string(),
                                           std::strerror(errno)));
  }
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const auto tmp = name.find(".tmp.");
    if (!is_solution_file(tmp == std::string::npos ? name : name.substr(0, tmp))) continue;
    if (tmp != std::string::npos) {
      remove_stale_temporaries((dir / name.substr(0, tmp)).string());
    } else if (::unlink(it->path().c_str()) != 0 && errno != ENOENT) {
      throw std::runtime_error(fmt::format("{}: cannot remove the earlier sweep's file: {}", it->path().string(),
                                           std::strerror(errno)));
    }
  }

  // one trajectory per solution
  for (const auto& s : solutions) {
    const VariantResult* r = find_result(results, s.first_variant);
    if (!r) continue;
    write_file_atomic((dir / fmt::format("solution_{}.csv", s.id)).string(),
                      trajectory_csv(*sweep.configurations[s.configuration].model, r->trajectory));
  }

  write_file_atomic((dir / "solutions.csv").string(), solutions_csv(results, solutions));

  // variants.csv, one row per variant started, written as it is formatted
  std::string header = "variant,configuration";
  for (const auto& axis : sweep.axes) header += "," + csv_cell(axis.key);
  header += ",guess,guess_points,status,iterations,residual,action,cost,certificate,solution,error,seconds\n";
  std::size_t next = 0;
  bool header_done = false;
  write_streamed_atomic((dir / "variants.csv").string(), [&](std::string& out) {
    if (!header_done) {
      out += header;
      header_done = true;
      return !results.empty();
    }
    const std::size_t i = next++;
    const VariantResult& r = results[i];
    const Variant v = make_variant(sweep, r.id);
    out += fmt::format("{},{}", r.id, r.configuration);
    for (const auto& value : sweep.configuration_values[r.configuration]) out += "," + csv_cell(value);
    out += fmt::format(",{},{},{},{},{},{},{},{},{},{},{}\n", v.guess_label, points_text(v.points), r.status,
                       r.iterations, format_double(r.residual), format_double(r.action), format_double(r.cost),
                       r.converged() ? csv_cell(certificate_verdict(r)) : "",
                       i < solution_of.size() && solution_of[i] > 0 ? std::to_string(solution_of[i]) : "",
                       r.status == "error" || r.status == "invalid_input" ? csv_cell(r.message) : "",
                       format_double(r.seconds));
    return next < results.size();
  });

  write_file_atomic(index_path, index);
}

nlohmann::ordered_json sweep_json(const Sweep& sweep, const std::vector<VariantResult>& results,
                                  const std::vector<Solution>& solutions, const SweepRunInfo& info) {
  const Scene& first = sweep.configurations.front();
  const PhysicalCost cost_kind = physical_cost(first, Summary{}, Trajectory{});  // for its name only
  nlohmann::ordered_json j;
  j["sweep"] = sweep.path;
  j["scene"] = sweep.scene_path;
  j["model"] = first.model->name;
  j["model_source"] = scene_model_source(first);
  j["discretization"] = first.discretization;
  j["cost"] = {{"name", cost_kind.name}, {"definition", cost_kind.definition}};
  j["set"] = sweep.sets;
  j["variants"] = sweep.variant_count();
  // After an interruption, the variants never started (not listed in variants.csv).
  j["not_started"] = static_cast<std::size_t>(sweep.variant_count()) - std::min(results.size(),
                                                                                 static_cast<std::size_t>(sweep.variant_count()));
  j["guesses_per_configuration"] = sweep.guesses_per_configuration();
  nlohmann::ordered_json configurations = nlohmann::ordered_json::array();
  for (std::size_t c = 0; c < sweep.configurations.size(); ++c) {
    const Scene& scene = sweep.configurations[c];
    nlohmann::ordered_json values = nlohmann::ordered_json::object();
    for (std::size_t a = 0; a < sweep.axes.size(); ++a) values[sweep.axes[a].key] = sweep.configuration_values[c][a];
    nlohmann::ordered_json params = nlohmann::ordered_json::object();
    for (int i = 0; i < scene.model->nparams; ++i) params[scene.model->param_names[i]] = scene.problem.params[i];
    configurations.push_back({{"id", c}, {"values", values}, {"N", scene.problem.N}, {"params", params},
                              {"method", to_string(scene.options.method)}, {"tol", scene.options.tol}});
  }
  j["configurations"] = configurations;
  j["ranks"] = info.ranks;
  j["threads"] = info.threads;
  j["wall_seconds"] = info.wall_seconds;
  j["grouping"] = {{"action_tol", sweep.grouping.action_tol}, {"distance_tol", sweep.grouping.distance_tol}};
  std::map<std::string, int> by_status;
  int converged = 0;
  for (const auto& r : results) {
    if (r.converged()) ++converged;
    else ++by_status[r.status];
  }
  j["converged"] = converged;
  nlohmann::ordered_json failures = nlohmann::ordered_json::object();
  for (const auto& [status, count] : by_status) failures[status] = count;
  j["failures"] = failures;
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  const Solution* best = nullptr;
  for (const auto& s : solutions) {
    const VariantResult* r = find_result(results, s.first_variant);
    list.push_back({{"id", s.id}, {"configuration", s.configuration}, {"rank", s.rank}, {"cost", s.cost},
                    {"action", s.action}, {"residual", s.residual}, {"variants", s.variants.size()},
                    {"first_variant", s.first_variant}, {"certificate", r ? certificate_verdict(*r) : "unknown"},
                    {"trajectory", fmt::format("solution_{}.csv", s.id)}});
    if (!best || s.cost < best->cost) best = &s;
  }
  j["solutions_count"] = solutions.size();
  j["solutions"] = list;
  j["best"] = best ? list[static_cast<std::size_t>(best->id - 1)] : nlohmann::ordered_json(nullptr);
  return j;
}

namespace {

std::string short_number(double v) { return fmt::format("{:.10g}", v); }

}  // namespace

void print_sweep_report(const Sweep& sweep, const std::vector<VariantResult>& results,
                  const std::vector<Solution>& solutions, const SweepRunInfo& info, const std::string& out_dir) {
  std::map<std::string, int> failures;
  int converged = 0;
  for (const auto& r : results) {
    if (r.converged()) ++converged;
    else ++failures[r.status];
  }
  std::string failed;
  for (const auto& [status, count] : failures) failed += fmt::format("{}{} {}", failed.empty() ? "" : ", ", count, status);
  const std::size_t total = static_cast<std::size_t>(sweep.variant_count());
  if (results.size() < total) {
    failed += fmt::format("{}{} not started", failed.empty() ? "" : ", ", total - results.size());
  }
  const PhysicalCost kind = physical_cost(sweep.configurations.front(), Summary{}, Trajectory{});
  std::cout << fmt::format("sweep {}: {} variant{} on {} rank{}, {} converged{}, {} distinct solution{}, {:.3g} s\n",
                           sweep.path, total, total == 1 ? "" : "s", info.ranks,
                           info.ranks == 1 ? "" : "s", converged, failed.empty() ? "" : " (" + failed + ")",
                           solutions.size(), solutions.size() == 1 ? "" : "s", info.wall_seconds);
  if (solutions.empty()) return;
  const bool several = sweep.configurations.size() > 1;
  std::cout << fmt::format("{:>8}{}{:>5}  {:>18}  {:>18}  {:>9}  {:>8}  {}\n", "solution",
                           several ? fmt::format("{:>7}", "config") : "", "rank",
                           kind.name == "action" ? "cost (action)" : kind.name, "action", "residual",
                           "variants", "certificate");
  for (const auto& s : solutions) {
    const VariantResult* representative = find_result(results, s.first_variant);
    const std::string verdict = representative ? certificate_verdict(*representative) : "unknown";
    std::cout << fmt::format("{:>8}{}{:>5}  {:>18}  {:>18}  {:>9.2e}  {:>8}  {}\n", s.id,
                             several ? fmt::format("{:>7}", s.configuration) : "", s.rank, short_number(s.cost),
                             short_number(s.action), s.residual, s.variants.size(), verdict);
  }
  const Solution* best = &solutions.front();
  for (const auto& s : solutions) {
    if (s.cost < best->cost) best = &s;
  }
  std::cout << fmt::format("best: solution {}, {} = {} (first reached by variant {}, {})\n", best->id, kind.name,
                           format_double(best->cost), best->first_variant,
                           make_variant(sweep, best->first_variant).guess_label);
  std::cout << "output: " << out_dir << "\n";
}

}  // namespace pardel::app

/**
 * @file sweep.cpp
 * pardel.sweep: `pardel sweep` without its command line (pardel::app's sweeps), the variants solved
 * on a worker thread while the calling thread watches for Ctrl-C.
 */
#include "bindings.hpp"

#include <atomic>
#include <chrono>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "pardel/app/sweep.hpp"
#include "pardel/model_loader.hpp"

namespace pardel::python {

/**
 * `pardel sweep` without its command line: reads the sweep file (`overrides` as --set), solves
 * every variant with pardel::app's run_variants_over_ranks (one rank) on a worker thread, the GIL
 * released, while this thread checks Python's signals every 50 ms; a pending exception
 * (KeyboardInterrupt) stops the running solve, the variants not yet started end "interrupted", and
 * once the results are grouped (and written to `out` when given) a KeyboardInterrupt comes back as
 * "pending" with them (the package raises it, carrying the sweep so far), any other exception is
 * raised. The results come back as plain values, sweep.json's dictionary as a dict, and the
 * trajectories of the converged variants as arrays.
 */
py::dict run_sweep(const std::string& path, const std::vector<std::string>& overrides, int threads,
                   const std::string& out) {
  const app::Sweep sweep = app::load_sweep(path, overrides, resolve_spec, bundled_model_names());
  std::atomic<bool> stop{false};
  std::vector<app::VariantResult> results;
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<py::error_already_set> pending =
      watching_signals([&] { results = app::run_variants_over_ranks(sweep, threads, 0, 1, {}, &stop); }, stop);

  app::SweepRunInfo info;
  info.ranks = 1;
  info.threads = threads >= 0 ? threads : sweep.configurations.front().options.threads;
  info.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::vector<int> solution_of;
  const std::vector<app::Solution> solutions = app::group_solutions(results, sweep.grouping, &solution_of);
  if (!out.empty()) app::write_sweep_outputs(sweep, results, solutions, solution_of, info, out);
  // A KeyboardInterrupt (Ctrl-C) is raised by the package with the sweep so far; any other
  // exception a signal handler raised is raised here.
  if (pending && !pending->matches(PyExc_KeyboardInterrupt)) throw std::move(*pending);

  py::list variants;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const app::VariantResult& r = results[i];
    const app::Variant v = app::make_variant(sweep, r.id);
    py::dict d;
    d["id"] = r.id;
    d["configuration"] = r.configuration;
    d["guess"] = v.guess_label;
    d["guess_points"] = v.points;
    d["status"] = r.status;
    d["message"] = r.message;
    d["iterations"] = r.iterations;
    d["residual"] = r.residual;
    d["action"] = r.action;
    d["cost"] = r.cost;
    d["seconds"] = r.seconds;
    d["certificate"] = r.converged() ? py::object(py::str(app::certificate_verdict(r))) : py::object(py::none());
    d["solution"] = i < solution_of.size() && solution_of[i] > 0 ? py::object(py::int_(solution_of[i])) : py::none();
    if (r.converged()) {
      d["t"] = vector(r.trajectory.t);
      d["q"] = matrix(r.trajectory.q, static_cast<std::size_t>(r.trajectory.N) + 1,
                      static_cast<std::size_t>(r.trajectory.dim));
    } else {
      d["t"] = py::none();
      d["q"] = py::none();
    }
    variants.append(d);
  }
  py::list groups;
  for (const app::Solution& s : solutions) {
    py::dict d;
    d["id"] = s.id;
    d["configuration"] = s.configuration;
    d["rank"] = s.rank;
    d["first_variant"] = s.first_variant;
    d["variants"] = s.variants;
    d["cost"] = s.cost;
    d["action"] = s.action;
    d["residual"] = s.residual;
    groups.append(d);
  }
  py::dict result;
  result["summary"] = json_value(app::sweep_json(sweep, results, solutions, info));
  result["axes"] = [&sweep] {
    std::vector<std::string> keys;
    for (const auto& axis : sweep.axes) keys.push_back(axis.key);
    return keys;
  }();
  result["configuration_values"] = sweep.configuration_values;
  result["variants"] = variants;
  result["solutions"] = groups;
  result["pending"] = pending && pending->value() ? pending->value() : py::none();
  return result;
}

}  // namespace pardel::python

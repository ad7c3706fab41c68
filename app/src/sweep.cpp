// The variants of a `pardel sweep` (configuration and guess), their solves, and the grouping of
// their answers into distinct solutions (see sweep.hpp for the contract; the sweep file is read in
// sweep_file.cpp, the outputs written in sweep_outputs.cpp).
#include "pardel/app/sweep.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <new>
#include <random>
#include <sstream>

#include <unistd.h>

#include "pardel/app/outputs.hpp"
#include "pardel/app/solve.hpp"
#include "pardel/app/trajectory_io.hpp"
#include "pardel/memory.hpp"
#include "pardel/regular_file.hpp"
#include "toml_read.hpp"

namespace pardel::app {

namespace fs = std::filesystem;

int Sweep::guesses_per_configuration() const {
  const int given = static_cast<int>(listed_guesses.size()) + random.count;
  return given > 0 ? given : 1;
}

int Sweep::variant_count() const {
  return static_cast<int>(configurations.size()) * guesses_per_configuration();
}

Variant make_variant(const Sweep& sweep, int id) {
  Variant v;
  v.id = id;
  const int per = sweep.guesses_per_configuration();
  v.configuration = id / per;
  v.guess = id % per;
  const int listed = static_cast<int>(sweep.listed_guesses.size());
  if (listed + sweep.random.count == 0) {
    v.guess_label = "scene";
    return v;
  }
  if (v.guess < listed) {
    v.guess_label = fmt::format("listed {}", v.guess);
    v.points = sweep.listed_guesses[v.guess];
    return v;
  }
  const int r = v.guess - listed;
  v.guess_label = fmt::format("random {}", r);
  const Problem& problem = sweep.configurations[v.configuration].problem;
  const int nc = problem.model->ncoords;
  const RandomGuessSpec& spec = sweep.random;
  const double* u = sweep.random_unit.data() + static_cast<std::size_t>(r) * spec.interior_points * nc;
  std::vector<double> q0(problem.q0.begin(), problem.q0.begin() + nc);
  std::vector<double> qN(problem.qN.begin(), problem.qN.begin() + nc);
  v.points.push_back(q0);
  for (int i = 0; i < spec.interior_points; ++i) {
    std::vector<double> point(nc);
    const double f = static_cast<double>(i + 1) / (spec.interior_points + 1);
    for (int j = 0; j < nc; ++j) {
      const double unit = u[static_cast<std::size_t>(i) * nc + j];
      point[j] = spec.in_box ? spec.box_min[j] + unit * (spec.box_max[j] - spec.box_min[j])
                             : q0[j] + f * (qN[j] - q0[j]) + (2 * unit - 1) * spec.spread;
    }
    v.points.push_back(std::move(point));
  }
  v.points.push_back(qN);
  return v;
}

VariantResult solve_variant(const Sweep& sweep, const Variant& variant, int threads, const std::atomic<bool>* stop) {
  VariantResult result;
  result.id = variant.id;
  result.configuration = variant.configuration;
  if (stop && stop->load()) {
    result.status = to_string(Termination::interrupted);
    result.message = "not started: the sweep was interrupted";
    result.cost = std::nan("");
    return result;
  }
  try {
    Scene scene = sweep.configurations.at(variant.configuration);
    if (!variant.points.empty()) {
      scene.guess.kind = GuessKind::polyline;
      scene.guess.points = variant.points;
    }
    if (threads >= 0) scene.options.threads = threads;
    // Each variant in this process (sweeps spread variants, not nodes, over ranks); refused before
    // anything of size N is allocated, as `pardel solve` refuses the scene.
    SolveRequest request;
    request.over_ranks = false;
    request.check_memory = sweep.memory_check;
    if (stop) {
      request.on_iteration = [stop](const IterationRecord&) { return !stop->load(); };
      request.stopped_by = [] { return std::string("the sweep's stop (Ctrl-C, SIGTERM or KeyboardInterrupt)"); };
    }
    Trajectory trajectory;  // the variant's scene's guess
    Summary summary;
    try {
      summary = run_solve(scene, trajectory, request).summary;
    } catch (const MemoryRefused& refused) {
      result.status = "error";
      result.message = "refused before solving: " + refused.reason() + " (--no-memory-check skips this check)";
      result.cost = std::nan("");
      return result;
    }
    result.status = to_string(summary.termination);
    result.message = summary.message;
    result.iterations = summary.iterations;
    result.residual = summary.residual;
    result.action = summary.action;
    result.seconds = summary.wall_seconds;
    const bool have_trajectory = trajectory.N >= 2 && static_cast<int>(trajectory.t.size()) == trajectory.N + 1;
    result.cost = have_trajectory ? physical_cost(scene, summary, trajectory).value : std::nan("");
    if (summary.converged() && have_trajectory) {
      // The solve's own point assessment (inertia from its factorization, O(N)).
      const PointAssessment& point = summary.point;
      result.certificate_valid = point.kind != PointKind::unknown;
      result.hessian_positive_definite = point.kind == PointKind::minimum;
      result.inertia_negative = point.negative;
      result.inertia_zero = point.zero;
      result.trajectory = std::move(trajectory);
    } else if (summary.converged()) {
      result.status = "error";
      result.message = "converged without a trajectory on the grid";
    }
  } catch (const OutOfMemory& error) {
    result = VariantResult{};
    result.id = variant.id;
    result.configuration = variant.configuration;
    result.status = "error";
    result.cost = std::nan("");
    result.message = error.what();
  } catch (const std::exception& error) {
    result.status = "error";
    result.message = error.what();
  }
  return result;
}

std::string certificate_verdict(const VariantResult& result) {
  if (!result.certificate_valid) return "unknown";
  if (result.hessian_positive_definite) return "minimum";
  if (result.inertia_negative > 0) return fmt::format("saddle ({} negative)", result.inertia_negative);
  return fmt::format("degenerate ({} zero)", result.inertia_zero);
}

double trajectory_distance(const Trajectory& a, const Trajectory& b) {
  if (a.N != b.N || a.dim != b.dim || a.q.size() != b.q.size()) return std::numeric_limits<double>::infinity();
  double largest = 0;
  for (std::size_t i = 0; i < a.q.size(); ++i) {
    const double d = std::abs(a.q[i] - b.q[i]);
    if (std::isnan(d)) return std::numeric_limits<double>::infinity();  // not the same path
    largest = std::max(largest, d);
  }
  return largest;
}

bool same_solution(const VariantResult& a, const VariantResult& b, const GroupingOptions& options) {
  if (a.configuration != b.configuration) return false;
  // Actions that are not finite (a singular fixed end: 1/x with x(0) = 0 makes every variant's +inf)
  // match where they are the same infinity (inf - inf is NaN, and inf is within any relative
  // tolerance of -inf); then the paths decide.
  const bool finite = std::isfinite(a.action) && std::isfinite(b.action);
  const bool same_action =
      finite ? std::abs(a.action - b.action) <= options.action_tol * std::max(1.0, std::abs(a.action))
             : a.action == b.action;
  if (!same_action) return false;
  return trajectory_distance(a.trajectory, b.trajectory) <= options.distance_tol;
}

std::vector<Solution> group_solutions(const std::vector<VariantResult>& results, const GroupingOptions& options,
                                      std::vector<int>* solution_of) {
  std::vector<Solution> groups;
  std::vector<std::size_t> representative;  // index into results
  std::vector<int> group_of(results.size(), -1);
  std::map<int, std::size_t> group_of_representative;  // variant id -> group
  for (std::size_t i = 0; i < results.size(); ++i) {
    const VariantResult& r = results[i];
    if (!r.converged()) continue;
    // Matched while the sweep ran (its trajectory released): the same comparisons, made then.
    const auto known = r.same_as >= 0 ? group_of_representative.find(r.same_as) : group_of_representative.end();
    if (known != group_of_representative.end()) {
      group_of[i] = static_cast<int>(known->second);
      groups[known->second].variants.push_back(r.id);
      continue;
    }
    for (std::size_t g = 0; g < groups.size(); ++g) {
      if (same_solution(results[representative[g]], r, options)) {
        group_of[i] = static_cast<int>(g);
        groups[g].variants.push_back(r.id);
        break;
      }
    }
    if (group_of[i] >= 0) continue;
    Solution s;
    s.configuration = r.configuration;
    s.first_variant = r.id;
    s.variants.push_back(r.id);
    s.cost = r.cost;
    s.action = r.action;
    s.residual = r.residual;
    group_of[i] = static_cast<int>(groups.size());
    group_of_representative[r.id] = groups.size();
    groups.push_back(std::move(s));
    representative.push_back(i);
  }
  std::vector<std::size_t> order(groups.size());
  for (std::size_t g = 0; g < order.size(); ++g) order[g] = g;
  std::stable_sort(order.begin(), order.end(), [&groups](std::size_t x, std::size_t y) {
    const Solution& a = groups[x];
    const Solution& b = groups[y];
    if (a.configuration != b.configuration) return a.configuration < b.configuration;
    if (a.cost != b.cost) return a.cost < b.cost;  // NaN costs keep their place among equals
    return a.first_variant < b.first_variant;
  });
  std::vector<Solution> sorted;
  std::vector<int> id_of_group(groups.size());
  int rank = 0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    Solution s = groups[order[k]];
    s.id = static_cast<int>(k) + 1;
    rank = (k > 0 && sorted.back().configuration == s.configuration) ? rank + 1 : 1;
    s.rank = rank;
    id_of_group[order[k]] = s.id;
    sorted.push_back(std::move(s));
  }
  if (solution_of) {
    solution_of->assign(results.size(), 0);
    for (std::size_t i = 0; i < results.size(); ++i) {
      if (group_of[i] >= 0) (*solution_of)[i] = id_of_group[group_of[i]];
    }
  }
  return sorted;
}

}  // namespace pardel::app

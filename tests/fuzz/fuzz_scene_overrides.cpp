/**
 * @file fuzz_scene_overrides.cpp
 * Fuzz entry for `--set KEY=VALUE` overrides (pardel::app::parse_scene's override path) applied
 * to valid scenes. The input's first line names one of the base scenes below (an unknown name
 * selects the first, and the line is then an override too); every further line is one override,
 * cut at its first NUL byte as a command-line argument would be. The base scenes cover an order-1
 * model with params, an order-2 model with knots and a polyline guess, an order-3 model with
 * velocity and acceleration boundary values, and a clock model. Contract checked on every input:
 *   - parse_scene either returns a scene or throws SceneError; any other exception, a crash, a
 *     hang or a leak is a defect;
 *   - a SceneError reads "--set OVERRIDE: error: MESSAGE" for one of the given overrides, exactly
 *     as given, or "base.toml:LINE:COL: error: " (LINE inside the base scene) or
 *     "base.toml: error: ";
 *   - an accepted scene has boundary values of the model's size, a grid with a finite end time and
 *     a non-zero step, and its linear or polyline initial guess (built when (N+1)·dim ≤ 10^6)
 *     lies on the scene's grid and starts and ends at the boundary values.
 * Built as a libFuzzer target with clang (fuzz_scene_overrides) and, with any compiler, as a
 * corpus replay program (fuzz_scene_overrides_replay, see corpus_replay_main.cpp).
 */
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "pardel/app/scene.hpp"
#include "fuzz_registry.hpp"
#include "pardel/pardel.hpp"

namespace {

const char kSourceName[] = "base.toml";

struct BaseScene {
  const char* name;
  const char* text;
};

const BaseScene kBases[] = {
    {"fuel_nav",
     "model = \"fuel_nav\"\ndiscretization = \"midpoint\"\n[params]\nc = 40\n[grid]\nt0 = 0\nT = 30\nN = 12\n"
     "[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n[solver]\nmethod = \"newton\"\ntol = 1e-9\nmax_iterations = 50\n"
     "[output]\ndir = \"out/fuel\"\n"},
    {"interp_fuel",
     "model = \"interp_fuel\"\n[grid]\nT = 6\nN = 12\n[boundary]\nq0 = [0, 0]\nv0 = [0, 0]\nqN = [3, 5]\n"
     "vN = [0, 0]\n[[knots]]\nt = 2.0\nq = [1, 3]\n[[knots]]\nt = 4\nq = [5, 2]\n[guess]\nkind = \"polyline\"\n"
     "points = [[0, 0], [1, 3], [5, 2], [3, 5]]\n[solver]\nrefine = { start_N = 4, factor = 1.5 }\n"},
    {"min_jerk",
     "model = \"min_jerk\"\ndiscretization = \"hermite_gauss(s=3)\"\n[grid]\nT = 4\nN = 8\n[boundary]\n"
     "q0 = [0, 0, 0]\nv0 = [0, 0, 0]\na0 = [0, 0, 0]\nqN = [4, 0, 1]\nvN = [0, 0, 0]\naN = [0, 0, 0]\n"},
    {"zermelo",
     "model = \"zermelo\"\n[grid]\nT = 1\nN = 10\n[boundary]\nq0 = [0, 0]\nqN = [6, 2]\n[guess]\n"
     "kind = \"polyline\"\npoints = [[0,0],[1,3.5],[4,5.5],[6,2]]\n[solver]\nclock = \"free_final_time\"\n"
     "clock_update_every = 5\n"},
};

[[noreturn]] void violated(const std::string& what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_scene_overrides: contract violated: %s\n%s\n", what.c_str(), detail.c_str());
  std::abort();
}

using pardel_fuzz::count_lines;
using pardel_fuzz::resolve;

void check_error(const std::string& base, const std::vector<std::string>& overrides, const std::string& what) {
  if (what.rfind("--set ", 0) == 0) {
    for (const std::string& o : overrides)
      if (what.rfind("--set " + o + ": error: ", 0) == 0 && what.size() > o.size() + 15) return;
    violated("--set diagnostic that does not name one of the overrides as given", what);
  }
  const std::string head = std::string(kSourceName) + ":";
  if (what.rfind(head, 0) != 0) violated("diagnostic names neither an override nor the scene", what);
  if (what.rfind(head + " error: ", 0) == 0) return;
  unsigned long line = 0, column = 0;
  int consumed = 0;
  if (std::sscanf(what.c_str() + head.size(), "%lu:%lu: error: %n", &line, &column, &consumed) != 2 || consumed == 0)
    violated("diagnostic is neither FILE:LINE:COL: error: nor FILE: error:", what);
  if (line < 1 || line > count_lines(base) || column < 1)
    violated("diagnostic position outside the base scene (" + std::to_string(count_lines(base)) + " lines)", what);
}

void check_scene(const pardel::app::Scene& scene) {
  const pardel::Problem& problem = scene.problem;
  if (!scene.model || problem.model != scene.model) violated("accepted scene without its model", scene.model_spec);
  const std::size_t dim = static_cast<std::size_t>(scene.model->dim);
  if (problem.q0.size() != dim || problem.qN.size() != dim) violated("boundary sizes differ from the model's dim", "");
  if (!(problem.T > 0) || problem.N < 2) violated("accepted a grid with T <= 0 or N < 2", "");
  if (!std::isfinite(problem.t0 + problem.T) || !(problem.T / problem.N > 0))
    violated("accepted a grid whose end time t0 + T is not finite or whose step T/N is zero", "");
  if (scene.guess.kind == pardel::app::GuessKind::csv || (problem.N + 1.0) * dim > 1e6) return;
  const pardel::Trajectory guess = pardel::app::make_initial_guess(scene);
  if (guess.N != problem.N || guess.dim != scene.model->dim ||
      guess.q.size() != static_cast<std::size_t>(problem.N + 1) * dim ||
      guess.t.size() != static_cast<std::size_t>(problem.N) + 1) {
    violated("initial guess of the wrong size", "");
  }
  for (std::size_t i = 0; i < dim; ++i) {
    if (guess.node(0)[i] != problem.q0[i] || guess.node(problem.N)[i] != problem.qN[i])
      violated("initial guess does not start and end at the boundary values", "");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> lines;
  for (std::size_t start = 0; start <= input.size();) {
    const std::size_t nl = input.find('\n', start);
    lines.push_back(input.substr(start, nl == std::string::npos ? std::string::npos : nl - start));
    if (nl == std::string::npos) break;
    start = nl + 1;
  }
  const BaseScene* base = &kBases[0];
  std::size_t first = 0;
  for (const BaseScene& b : kBases) {
    if (lines[0] == b.name) {
      base = &b;
      first = 1;
    }
  }
  std::vector<std::string> overrides;
  for (std::size_t i = first; i < lines.size(); ++i) {
    const std::string line = lines[i].substr(0, lines[i].find('\0'));  // an argument ends at its first NUL
    if (!line.empty()) overrides.push_back(line);
  }
  static const std::vector<std::string> names = pardel::bundled_model_names();
  try {
    check_scene(pardel::app::parse_scene(base->text, kSourceName, overrides, resolve, names));
  } catch (const pardel::app::SceneError& error) {
    check_error(base->text, overrides, error.what());
  } catch (const std::exception& error) {
    violated("parse_scene threw something other than SceneError", error.what());
  }
  return 0;
}

// Scene parsing and checking, one reader per TOML table (see scene.hpp for the contract).
#include "pardel/app/scene.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "pardel/app/trajectory_io.hpp"
#include "pardel/regular_file.hpp"
#include "scene_reader.hpp"
#include "toml_read.hpp"
#include "pardel/app/scene_table.hpp"  // after toml_read.hpp, which sets toml++'s options

namespace pardel::app {

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + cost});
      diagonal = up;
    }
  }
  return row[b.size()];
}

std::string nearest_name(std::string_view word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = std::string::npos;
  for (const auto& candidate : candidates) {
    const std::size_t d = edit_distance(word, candidate);
    if (d < best_distance) {
      best_distance = d;
      best = candidate;
    }
  }
  // A plausible typo: at most a third of the longer word changed (and at least one edit allowed).
  const std::size_t longest = std::max(word.size(), best.size());
  const std::size_t allowed = std::max<std::size_t>(1, (longest + 2) / 3);
  return best_distance <= allowed ? best : std::string();
}

std::string boundary_prefix(int d) {
  switch (d) {
    case 0: return "q";
    case 1: return "v";
    case 2: return "a";
    case 3: return "j";
    default: return "d" + std::to_string(d) + "_";
  }
}


namespace {

using detail::SceneReader;
using detail::type_name;

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (;;) {
    const std::size_t pos = text.find(separator, start);
    parts.push_back(text.substr(start, pos == std::string::npos ? std::string::npos : pos - start));
    if (pos == std::string::npos) return parts;
    start = pos + 1;
  }
}

bool is_bare_key(const std::string& key) {
  if (key.empty()) return false;
  return std::all_of(key.begin(), key.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

/** Applies one --set KEY=VALUE to the document; returns the dotted key. */
std::string apply_override(toml::table& root, const std::string& assignment) {
  const std::string origin = "--set " + assignment;
  const auto eq = assignment.find('=');
  if (eq == std::string::npos) {
    throw SceneError(fmt::format("{}: error: expected KEY=VALUE (e.g. solver.method=newton)", origin));
  }
  const std::string dotted = assignment.substr(0, eq);
  const std::string text = assignment.substr(eq + 1);
  const auto path = split(dotted, '.');
  for (const auto& segment : path) {
    if (!is_bare_key(segment)) {
      throw SceneError(fmt::format("{}: error: '{}' is not a key path (keys joined by '.', e.g. grid.N)", origin, dotted));
    }
  }
  toml::table snippet;
  const std::string document = "value = " + text;
  try {
    check_ascii_outside_strings(document, origin);
    snippet = toml::parse(std::string_view(document), std::string_view("--set"));
  } catch (const std::exception&) {
    snippet = toml::table{};
    snippet.insert_or_assign("value", text);  // not a TOML value: take it as a string
  }
  toml::table* table = &root;
  std::string walked;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    walked += (i ? "." : "") + path[i];
    toml::node* next = table->get(path[i]);
    if (!next) {
      table->insert_or_assign(path[i], toml::table{});
      next = table->get(path[i]);
    }
    if (!next->is_table()) {
      throw SceneError(fmt::format("{}: error: {} is {}, not a table; cannot set {}", origin, walked,
                                   type_name(*next), dotted));
    }
    table = next->as_table();
  }
  const toml::node& value = *snippet.get("value");
  value.visit([&](const auto& v) { table->insert_or_assign(path.back(), v); });
  return dotted;
}

}  // namespace

/**
 * Refuses non-ASCII bytes outside strings and comments before toml++ sees them: toml++ 3.3.0
 * reaches undefined behaviour on some non-ASCII code points where whitespace may stand.
 */
void check_ascii_outside_strings(std::string_view text, const std::string& source_name) {
  enum class State { normal, comment, basic, literal, multi_basic, multi_literal };
  State state = State::normal;
  const std::string_view triple_double = "\"\"\"";
  const std::string_view triple_single = "'''";
  long line = 1, column = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    ++column;
    if (c == '\n') {
      ++line;
      column = 0;
      if (state == State::comment || state == State::basic || state == State::literal) state = State::normal;
      continue;
    }
    auto starts = [&](std::string_view token) { return text.substr(i, token.size()) == token; };
    switch (state) {
      case State::normal:
        if (static_cast<unsigned char>(c) >= 0x80) {
          throw SceneError(fmt::format("{}:{}:{}: error: non-ASCII character outside a string or comment",
                                       source_name, line, column));
        }
        if (c == '#') {
          state = State::comment;
        } else if (starts(triple_double)) {
          state = State::multi_basic;
          i += 2;
          column += 2;
        } else if (starts(triple_single)) {
          state = State::multi_literal;
          i += 2;
          column += 2;
        } else if (c == '"') {
          state = State::basic;
        } else if (c == '\'') {
          state = State::literal;
        }
        break;
      case State::comment:
        break;
      case State::basic:
        if (c == '\\' && i + 1 < text.size() && text[i + 1] != '\n') {
          ++i;
          ++column;
        } else if (c == '"') {
          state = State::normal;
        }
        break;
      case State::literal:
        if (c == '\'') state = State::normal;
        break;
      case State::multi_basic:
        if (c == '\\' && i + 1 < text.size() && text[i + 1] != '\n') {
          ++i;
          ++column;
        } else if (starts(triple_double)) {
          state = State::normal;
          i += 2;
          column += 2;
        }
        break;
      case State::multi_literal:
        if (starts(triple_single)) {
          state = State::normal;
          i += 2;
          column += 2;
        }
        break;
    }
  }
}

namespace {

/** A parsed scene read and checked, one table at a time; `origins` names the --set that supplied
 *  a key (parse_scene's overrides). */
Scene read_scene(const toml::table& root, const std::string& source_name, std::map<std::string, std::string> origins,
                 const ModelResolver& resolve, const std::vector<std::string>& model_names) {
  const SceneReader r(source_name, std::move(origins));

  Scene scene;
  scene.path = source_name;
  r.check_keys(root, "", {"model", "discretization", "params", "grid", "boundary", "knots", "guess", "solver", "output"});

  read_model(r, root, resolve, model_names, scene);
  read_discretization(r, root, scene);
  read_params(r, root, scene);
  read_grid(r, root, scene);
  read_boundary(r, root, scene);
  read_solver(r, root, scene);
  read_knots(r, root, scene);
  read_guess(r, root, scene);
  read_output(r, root, scene);
  if (scene.options.accuracy > 0) {
    const toml::node* accuracy = r.table(root, "grid", "grid")->get("accuracy");
    if (scene.problem.clock != ClockMode::none)
      r.fail(*accuracy, "grid.accuracy", "an adaptive grid (grid.accuracy) needs solver.clock = \"none\": the clock sets the node times");
    if (!scene.options.error_estimate)
      r.fail(*accuracy, "grid.accuracy", "an adaptive grid (grid.accuracy) needs the error estimate; solver.error_estimate is false");
  }

  std::string why;
  const toml::table* solver = r.table(root, "solver", "solver");
  if (!scene.options.is_valid(&why)) {
    throw SceneError(fmt::format("{}: error: invalid solver options: {}", r.where(solver ? solver->source()
                                                                                        : toml::source_region{},
                                                                                 "solver"),
                                 why));
  }
  return scene;
}

}  // namespace

Scene parse_scene(std::string_view text, const std::string& source_name, const std::vector<std::string>& overrides,
                  const ModelResolver& resolve, const std::vector<std::string>& model_names) {
  toml::table root = detail::parse_document(text, source_name);
  std::map<std::string, std::string> origins;
  for (const auto& assignment : overrides) {
    const std::string dotted = apply_override(root, assignment);
    origins[dotted] = "--set " + assignment;
  }
  return read_scene(root, source_name, std::move(origins), resolve, model_names);
}

Scene read_scene_table(const toml::table& root, const std::string& source_name, const ModelResolver& resolve,
                       const std::vector<std::string>& model_names) {
  return read_scene(root, source_name, {}, resolve, model_names);
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides, const ModelResolver& resolve,
                 const std::vector<std::string>& model_names) {
  std::string text;
  try {
    text = pardel::read_regular_file(path, pardel::FileLimits::scene, "scene file");
  } catch (const pardel::FileError& error) {
    throw SceneError(error.what());
  }
  return parse_scene(text, path, overrides, resolve, model_names);
}

Trajectory make_initial_guess(const Scene& scene) {
  switch (scene.guess.kind) {
    case GuessKind::linear: return linear_guess(scene.problem);
    case GuessKind::polyline: return polyline_guess(scene.problem, scene.guess.points);
    case GuessKind::csv: {
      Trajectory from;
      try {
        from = read_trajectory_csv(scene.guess.csv_path, *scene.model);
      } catch (const std::runtime_error& error) {
        throw SceneError(error.what());
      }
      if (from.N == scene.problem.N) {
        // Boundary values come from the scene, not the file.
        std::copy(scene.problem.q0.begin(), scene.problem.q0.end(), from.node(0));
        std::copy(scene.problem.qN.begin(), scene.problem.qN.end(), from.node(from.N));
        return from;
      }
      return resample(scene.problem, from, scene.problem.N);
    }
  }
  return linear_guess(scene.problem);
}

}  // namespace pardel::app

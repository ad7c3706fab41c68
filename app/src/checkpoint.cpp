// Checkpoint files of `pardel solve` (see checkpoint.hpp): writing, exact reading and checks.
#include "pardel/app/checkpoint.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "pardel/app/outputs.hpp"
#include "pardel/app/trajectory_io.hpp"
#include "pardel/regular_file.hpp"

namespace pardel::app {
namespace {

using json = nlohmann::json;
constexpr const char* kFormat = "pardel-checkpoint";

/** A double as JSON: finite values as numbers (nlohmann writes them so that they read back
 *  exactly), the others as the strings "inf", "-inf", "nan". */
json number(double v) {
  if (std::isfinite(v)) return v;
  if (std::isnan(v)) return "nan";
  return v > 0 ? "inf" : "-inf";
}

json numbers(const std::vector<double>& values) {
  json out = json::array();
  for (double v : values) out.push_back(number(v));
  return out;
}

/** Reads the fields of the checkpoint body, naming the key of anything wrong. */
class Reader {
 public:
  explicit Reader(const std::string& path) : path_(path) {}

  [[noreturn]] void fail(const std::string& message) const {
    throw CheckpointError(fmt::format("{}: error: {}", path_, message));
  }

  const json& at(const json& object, const char* key, const std::string& where) const {
    if (!object.is_object()) fail(fmt::format("{} is not an object", where));
    const auto it = object.find(key);
    if (it == object.end()) fail(fmt::format("missing key {}.{}", where, key));
    return *it;
  }

  long integer(const json& object, const char* key, const std::string& where, long lo, long hi) const {
    return integer(at(object, key, where), fmt::format("key {}.{}", where, key), lo, hi);
  }

  /** An integer in [lo, hi]; one beyond `long` (an unsigned JSON number) is out of range too. */
  long integer(const json& v, const std::string& what, long lo, long hi) const {
    if (!v.is_number_integer()) fail(fmt::format("{} must be an integer", what));
    if (v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(hi))
      fail(fmt::format("{} = {} is out of range [{}, {}]", what, v.get<std::uint64_t>(), lo, hi));
    const long value = v.get<long>();
    if (value < lo || value > hi) fail(fmt::format("{} = {} is out of range [{}, {}]", what, value, lo, hi));
    return value;
  }

  double real(const json& v, const std::string& what) const {
    if (v.is_number()) return v.get<double>();
    if (v.is_string()) {
      const std::string s = v.get<std::string>();
      if (s == "inf") return std::numeric_limits<double>::infinity();
      if (s == "-inf") return -std::numeric_limits<double>::infinity();
      if (s == "nan") return std::numeric_limits<double>::quiet_NaN();
    }
    fail(fmt::format("{} must be a number (or \"inf\", \"-inf\", \"nan\")", what));
  }

  double real(const json& object, const char* key, const std::string& where) const {
    return real(at(object, key, where), fmt::format("key {}.{}", where, key));
  }

  std::string text(const json& object, const char* key, const std::string& where) const {
    const json& v = at(object, key, where);
    if (!v.is_string()) fail(fmt::format("key {}.{} must be a string", where, key));
    return v.get<std::string>();
  }

  std::vector<double> reals(const json& object, const char* key, const std::string& where) const {
    const json& v = at(object, key, where);
    if (!v.is_array()) fail(fmt::format("key {}.{} must be an array of numbers", where, key));
    std::vector<double> out;
    out.reserve(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) out.push_back(real(v[i], fmt::format("{}.{}[{}]", where, key, i)));
    return out;
  }

 private:
  std::string path_;
};

}  // namespace

std::string fnv1a_hex(const std::string& bytes) {
  std::uint64_t h = 14695981039346656037ULL;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  return fmt::format("{:016x}", h);
}

std::string model_digest(const pardel_model& model, const std::string& lag_path) {
  if (!lag_path.empty())  // through the one reader of users' files (a FIFO or device is refused, not read)
    return fnv1a_hex("lag\n" + pardel::read_regular_file(lag_path, pardel::FileLimits::lag, ".lag file"));
  std::string d = fmt::format("abi {}\nname {}\norder {} ncoords {} dim {}\ntime_dependent {} clock {}\ncost {} {}\n",
                              model.abi_version, model.name ? model.name : "", model.order, model.ncoords, model.dim,
                              model.time_dependent, model.clock != nullptr, model.cost_name ? model.cost_name : "",
                              model.cost_kind);
  for (int i = 0; i < model.ncoords; ++i) d += fmt::format("coord {}\n", model.coords[i]);
  for (int i = 0; i < model.nparams; ++i)
    d += fmt::format("param {} = {:.17g}\n", model.param_names[i], model.param_defaults[i]);
  // The kernels at a fixed point: an edit of L that keeps every name shows in their values.
  const int m = model.dim;
  std::vector<double> q0(m), q1(m), D1(m), D2(m), D11(m * m), D12(m * m), D22(m * m);
  for (int i = 0; i < m; ++i) {
    q0[i] = 0.3 + 0.11 * i;
    q1[i] = 0.4 + 0.07 * i;
  }
  std::vector<double> p(model.param_defaults, model.param_defaults + model.nparams);
  const auto values = [](const std::vector<double>& v) {
    std::string out;
    for (const double x : v) out += fmt::format(" {:.12g}", x);
    return out;
  };
  for (int k = 0; k < model.ndiscretizations; ++k) {
    const pardel_discretization& disc = model.discretizations[k];
    d += fmt::format("discretization {} order {}\n", disc.name, disc.consistency_order);
    if (!disc.full) continue;
    double Ld = 0;
    disc.full(0.05, 0.2, 0.25, q0.data(), q1.data(), p.data(), &Ld, D1.data(), D2.data(), D11.data(), D12.data(),
              D22.data());
    d += fmt::format("Ld {:.12g}\n", Ld) + values(D1) + values(D2) + values(D11) + values(D12) + values(D22) + "\n";
  }
  if (model.clock) d += fmt::format("clock {:.12g}\n", model.clock(0.05, 0.2, q0.data(), q1.data(), p.data()));
  return fnv1a_hex(d);
}

namespace {

/** Whether `text` is valid UTF-8 (what a JSON string may hold). */
bool is_utf8(const std::string& text) {
  try {
    (void)json(text).dump();
    return true;
  } catch (const json::type_error&) {
    return false;
  }
}

json body_json(const Checkpoint& c) {
  const SolverState& s = c.state;
  json history = json::array();
  for (const IterationRecord& r : s.history)
    history.push_back({r.iteration, r.N, number(r.residual), number(r.action), number(r.seconds)});
  json state = {
      {"version", SolverState::kFormatVersion},
      {"method", to_string(s.method)},
      {"level", s.level},
      {"N", s.N},
      {"iteration", s.iteration},
      {"level_iteration", s.level_iteration},
      {"since_clock_update", s.since_clock_update},
      {"next_record", s.next_record},
      {"best_iteration", s.best_iteration},
      {"have_initial_residual", s.have_initial_residual},
      {"initial_residual", number(s.initial_residual)},
      {"last_good_residual", number(s.last_good_residual)},
      {"best_residual", number(s.best_residual)},
      {"level_initial_residual", number(s.level_initial_residual)},
      {"level_checkpoint_residual", number(s.level_checkpoint_residual)},
      {"seconds", number(s.seconds)},
      {"method_state", numbers(s.method_state)},
      {"component_start_scale", numbers(s.component_start_scale)},
      {"component_previous_residual", numbers(s.component_previous_residual)},
      {"dim", s.trajectory.dim},
      {"t", numbers(s.trajectory.t)},
      {"q", numbers(s.trajectory.q)},
      {"history", history},
      {"previous_level", {{"N", s.previous_level.N},
                          {"t", numbers(s.previous_level.t)},
                          {"q", numbers(s.previous_level.q)}}},
  };
  json scene = {{"path", c.scene_path}, {"hash", c.scene_hash}, {"overrides", c.overrides}, {"threads", c.threads}};
  // A path that is not UTF-8 cannot be a JSON string: "path" shows it with U+FFFD for its invalid
  // bytes (checkpoint_json), "path_bytes" holds its bytes, from which parse_checkpoint reads it.
  if (!is_utf8(c.scene_path))
    scene["path_bytes"] = std::vector<unsigned char>(c.scene_path.begin(), c.scene_path.end());
  return {
      {"scene", scene},
      {"model", c.model_digest.empty() ? json{{"name", c.model}, {"dim", c.dim}}
                                       : json{{"name", c.model}, {"dim", c.dim}, {"digest", c.model_digest}}},
      {"state", state},
  };
}

}  // namespace

std::string checkpoint_json(const Checkpoint& checkpoint) {
  // The checksum covers the compact text of the body; nlohmann's objects keep their keys sorted,
  // so parsing and dumping the body again gives the same text.
  // A path that is not UTF-8 (a scene's) is written with U+FFFD for its invalid bytes, never thrown.
  const std::string body = body_json(checkpoint).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return fmt::format("{{\"format\": \"{}\", \"version\": {}, \"checksum\": \"{}\",\n\"body\": {}}}\n", kFormat,
                     Checkpoint::kVersion, fnv1a_hex(body), body);
}

namespace {

/** The deepest nesting of arrays and objects in JSON text (brackets inside strings not counted). */
std::size_t json_nesting(const std::string& text) {
  std::size_t depth = 0, deepest = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return deepest;
}

/** The checkpoint's text parsed as JSON, its format and version checked. */
json parse_checked(const std::string& text, const Reader& rd) {
  // A checkpoint nests 5 levels deep; far deeper text would exhaust the stack when the body is
  // dumped again for its checksum (200 000 levels crashed pardel), so it is refused before parsing.
  constexpr std::size_t kMaxNesting = 64;
  if (json_nesting(text) > kMaxNesting)
    rd.fail(fmt::format("not a pardel checkpoint (JSON nested more than {} levels deep)", kMaxNesting));
  json file;
  try {
    file = json::parse(text);
  } catch (const json::parse_error& error) {
    rd.fail(fmt::format("not a valid checkpoint (JSON parse error at byte {}); the file is truncated or corrupted",
                        error.byte));
  } catch (const json::out_of_range& error) {
    // A number beyond double's range ("1e400"): nlohmann reports it without a position.
    const std::string what = error.what();
    rd.fail(fmt::format("not a valid checkpoint (JSON {}); the file is corrupted", what.substr(what.find(']') + 2)));
  }
  if (!file.is_object()) rd.fail("not a checkpoint (the top level is not a JSON object)");
  const auto format = file.find("format");
  if (format == file.end() || !format->is_string() || format->get<std::string>() != kFormat)
    rd.fail(fmt::format("not a pardel checkpoint (key \"format\" is not \"{}\")", kFormat));
  const long version = rd.integer(file, "version", "checkpoint", 0, std::numeric_limits<int>::max());
  if (version != Checkpoint::kVersion)
    rd.fail(fmt::format("checkpoint format version {} is not supported (this pardel reads version {})", version,
                        Checkpoint::kVersion));
  return file;
}

/** The file's body, its recorded checksum checked against its own. */
const json& checked_body(const json& file, const Reader& rd) {
  const std::string checksum = rd.text(file, "checksum", "checkpoint");
  const json& body = rd.at(file, "body", "checkpoint");
  const std::string actual = fnv1a_hex(body.dump());
  if (actual != checksum)
    rd.fail(fmt::format("checksum mismatch (recorded {}, computed {}): the file was modified or corrupted", checksum,
                        actual));
  return body;
}

/** body.scene and body.model into `c`. */
void read_scene_and_model(const json& body, const Reader& rd, Checkpoint& c) {
  const json& scene = rd.at(body, "scene", "body");
  c.scene_path = rd.text(scene, "path", "scene");
  if (scene.is_object() && scene.contains("path_bytes")) {  // a path that is not UTF-8, byte by byte
    const json& bytes = scene["path_bytes"];
    if (!bytes.is_array()) rd.fail("key scene.path_bytes must be an array of bytes (integers 0 to 255)");
    std::string path;
    for (const json& b : bytes) {
      if (!b.is_number_integer() || b.get<long long>() < 0 || b.get<long long>() > 255)
        rd.fail("key scene.path_bytes must be an array of bytes (integers 0 to 255)");
      path += static_cast<char>(b.get<long long>());
    }
    c.scene_path = path;
  }
  c.scene_hash = rd.text(scene, "hash", "scene");
  const json& overrides = rd.at(scene, "overrides", "scene");
  if (!overrides.is_array()) rd.fail("key scene.overrides must be an array of strings");
  for (const json& o : overrides) {
    if (!o.is_string()) rd.fail("key scene.overrides must be an array of strings");
    c.overrides.push_back(o.get<std::string>());
  }
  // -1: no --threads; else within the bound of Options::threads.
  const auto max_threads = static_cast<long>(option_bound("threads")->high);
  c.threads = static_cast<int>(rd.integer(scene, "threads", "scene", -1, max_threads));
  const json& model = rd.at(body, "model", "body");
  c.model = rd.text(model, "name", "model");
  c.dim = static_cast<int>(rd.integer(model, "dim", "model", 1, 1 << 20));
  if (model.is_object() && model.contains("digest")) {  // absent in checkpoints written before it was kept
    c.model_digest = rd.text(model, "digest", "model");
    if (c.model_digest.size() != 16 || c.model_digest.find_first_not_of("0123456789abcdef") != std::string::npos)
      rd.fail(fmt::format("key model.digest = \"{}\" is not 16 hex digits", c.model_digest));
  }
}

/** body.state's counters, residuals, method state and iterate into `c.state` (dim: c.dim). */
const json& read_state(const json& body, const Reader& rd, Checkpoint& c) {
  const json& st = rd.at(body, "state", "body");
  SolverState& s = c.state;
  const long state_version = rd.integer(st, "version", "state", 0, std::numeric_limits<int>::max());
  if (state_version != SolverState::kFormatVersion)
    rd.fail(fmt::format("solver state version {} is not supported (this pardel reads version {})", state_version,
                        SolverState::kFormatVersion));
  const std::string method = rd.text(st, "method", "state");
  if (!parse_method(method, &s.method)) rd.fail(fmt::format("key state.method: unknown method '{}'", method));
  constexpr long kMaxLong = std::numeric_limits<long>::max();
  s.level = static_cast<int>(rd.integer(st, "level", "state", 0, 1 << 20));
  s.N = static_cast<int>(rd.integer(st, "N", "state", 2, std::numeric_limits<int>::max()));
  s.iteration = rd.integer(st, "iteration", "state", 0, kMaxLong);
  s.level_iteration = rd.integer(st, "level_iteration", "state", 0, kMaxLong);
  s.since_clock_update = rd.integer(st, "since_clock_update", "state", 0, kMaxLong);
  s.next_record = rd.integer(st, "next_record", "state", 0, kMaxLong);
  s.best_iteration = rd.integer(st, "best_iteration", "state", 0, kMaxLong);
  const json& have = rd.at(st, "have_initial_residual", "state");
  if (!have.is_boolean()) rd.fail("key state.have_initial_residual must be true or false");
  s.have_initial_residual = have.get<bool>();
  s.initial_residual = rd.real(st, "initial_residual", "state");
  s.last_good_residual = rd.real(st, "last_good_residual", "state");
  s.best_residual = rd.real(st, "best_residual", "state");
  s.level_initial_residual = rd.real(st, "level_initial_residual", "state");
  s.level_checkpoint_residual = rd.real(st, "level_checkpoint_residual", "state");
  s.seconds = rd.real(st, "seconds", "state");
  s.method_state = rd.reals(st, "method_state", "state");
  // Per-component values: none or dim of them; absent in checkpoints written before they were kept.
  const auto per_component = [&](const char* key, std::vector<double>& values) {
    if (!st.contains(key)) return;
    values = rd.reals(st, key, "state");
    if (!values.empty() && values.size() != static_cast<std::size_t>(c.dim))
      rd.fail(fmt::format("key state.{} has {} values; dim = {} needs {}", key, values.size(), c.dim, c.dim));
  };
  per_component("component_start_scale", s.component_start_scale);
  per_component("component_previous_residual", s.component_previous_residual);
  s.trajectory.N = s.N;
  s.trajectory.dim = static_cast<int>(rd.integer(st, "dim", "state", 1, 1 << 20));
  s.trajectory.t = rd.reals(st, "t", "state");
  s.trajectory.q = rd.reals(st, "q", "state");
  const std::size_t n1 = static_cast<std::size_t>(s.N) + 1;
  if (s.trajectory.dim != c.dim) rd.fail(fmt::format("key state.dim = {} differs from model.dim = {}", s.trajectory.dim, c.dim));
  if (s.trajectory.t.size() != n1)
    rd.fail(fmt::format("key state.t has {} values; N = {} needs {}", s.trajectory.t.size(), s.N, n1));
  if (s.trajectory.q.size() != n1 * static_cast<std::size_t>(c.dim))
    rd.fail(fmt::format("key state.q has {} values; N = {} and dim = {} need {}", s.trajectory.q.size(), s.N, c.dim,
                        n1 * static_cast<std::size_t>(c.dim)));
  return st;
}

/** state.history: the records [iteration, N, residual, action, seconds]. */
void read_history(const json& st, const Reader& rd, SolverState& s) {
  constexpr long kMaxLong = std::numeric_limits<long>::max();
  const json& history = rd.at(st, "history", "state");
  if (!history.is_array()) rd.fail("key state.history must be an array");
  for (std::size_t i = 0; i < history.size(); ++i) {
    const json& h = history[i];
    const std::string where = fmt::format("state.history[{}]", i);
    if (!h.is_array() || h.size() != 5 || !h[0].is_number_integer() || !h[1].is_number_integer())
      rd.fail(fmt::format("{} must be [iteration, N, residual, action, seconds]", where));
    IterationRecord r;
    r.iteration = rd.integer(h[0], "key " + where + "[0] (iteration)", 0, kMaxLong);
    r.N = static_cast<int>(rd.integer(h[1], "key " + where + "[1] (N)", 0, std::numeric_limits<int>::max()));
    r.residual = rd.real(h[2], where + "[2]");
    r.action = rd.real(h[3], where + "[3]");
    r.seconds = rd.real(h[4], where + "[4]");
    s.history.push_back(r);
  }
}

/** state.previous_level: Newton's nested iteration, the previous level's solution (N = 0: none). */
void read_previous_level(const json& st, const Reader& rd, int dim, SolverState& s) {
  const json& previous = rd.at(st, "previous_level", "state");
  s.previous_level.N = static_cast<int>(rd.integer(previous, "N", "state.previous_level", 0, s.N));
  s.previous_level.t = rd.reals(previous, "t", "state.previous_level");
  s.previous_level.q = rd.reals(previous, "q", "state.previous_level");
  if (s.previous_level.N > 0) {
    s.previous_level.dim = dim;
    const std::size_t p1 = static_cast<std::size_t>(s.previous_level.N) + 1;
    if (s.previous_level.N < 2 || s.previous_level.t.size() != p1 ||
        s.previous_level.q.size() != p1 * static_cast<std::size_t>(dim))
      rd.fail(fmt::format("key state.previous_level: N = {} does not fit {} node times and {} values",
                          s.previous_level.N, s.previous_level.t.size(), s.previous_level.q.size()));
  } else if (!s.previous_level.t.empty() || !s.previous_level.q.empty()) {
    rd.fail("key state.previous_level: values given for N = 0");
  }
}

}  // namespace

Checkpoint parse_checkpoint(const std::string& text, const std::string& path) {
  const Reader rd(path);
  const json file = parse_checked(text, rd);
  const json& body = checked_body(file, rd);
  Checkpoint c;
  read_scene_and_model(body, rd, c);
  const json& st = read_state(body, rd, c);
  read_history(st, rd, c.state);
  read_previous_level(st, rd, c.dim, c.state);
  c.state.valid = true;
  return c;
}

Checkpoint read_checkpoint(const std::string& dir) {
  const std::string path = (std::filesystem::path(dir) / checkpoint_file_name()).string();
  // Only a regular file: a directory would read as empty, a FIFO would block forever.
  std::string text;
  try {
    text = pardel::read_regular_file(path, pardel::FileLimits::checkpoint, "checkpoint");
  } catch (const pardel::FileError& error) {
    throw CheckpointError(error.what());
  }
  return parse_checkpoint(text, path);
}

void write_checkpoint(const std::string& dir, const Checkpoint& checkpoint) {
  write_file_atomic((std::filesystem::path(dir) / checkpoint_file_name()).string(), checkpoint_json(checkpoint));
}

std::string scene_file_hash(const std::string& path) {
  try {
    return fnv1a_hex(pardel::read_regular_file(path, pardel::FileLimits::scene, "scene file"));
  } catch (const pardel::FileError& error) {
    throw SceneError(error.what());
  }
}

std::string check_resumable(const Checkpoint& checkpoint, const std::string& checkpoint_path, const Scene& scene,
                            const std::string& digest) {
  const std::string hash = scene_file_hash(checkpoint.scene_path);
  if (hash != checkpoint.scene_hash)
    throw CheckpointError(fmt::format("{}: error: the scene file {} changed since the checkpoint was written "
                                      "(hash {} then, {} now); the checkpoint cannot be resumed",
                                      checkpoint_path, checkpoint.scene_path, checkpoint.scene_hash, hash));
  if (checkpoint.model != scene.model->name || checkpoint.dim != scene.model->dim)
    throw CheckpointError(fmt::format("{}: error: the checkpoint is of model {} (dim {}), the scene now resolves to "
                                      "{} (dim {})",
                                      checkpoint_path, checkpoint.model, checkpoint.dim, scene.model->name,
                                      scene.model->dim));
  // The scene may name the same model whose .lag (or, compiled in, whose kernels) changed.
  if (checkpoint.model_digest.empty())
    return fmt::format("{}: warning: written by an earlier pardel without the model's digest; a change of model {} "
                       "since then cannot be detected",
                       checkpoint_path, scene.model->name);
  if (digest != checkpoint.model_digest)
    throw CheckpointError(fmt::format(
        "{}: error: the model {} changed since the checkpoint was written ({}; digest {} then, {} now); the "
        "checkpoint cannot be resumed",
        checkpoint_path, scene.model->name,
        scene.model_path.empty() ? "its kernels compiled into this pardel differ"
                                 : "its file " + scene_model_source(scene) + " was edited",
        checkpoint.model_digest, digest));
  return "";
}

bool update_checkpoint(const std::string& dir, const Summary& summary, const std::string& scene_path,
                       const std::vector<std::string>& overrides, int threads, const pardel_model& model,
                       const std::string& digest) {
  if (summary.termination == Termination::interrupted && summary.state.valid) {
    Checkpoint checkpoint;
    checkpoint.scene_path = scene_path;
    checkpoint.scene_hash = scene_file_hash(scene_path);
    checkpoint.overrides = overrides;
    checkpoint.threads = threads;
    checkpoint.model = model.name;
    checkpoint.dim = model.dim;
    checkpoint.model_digest = digest;
    checkpoint.state = summary.state;
    write_checkpoint(dir, checkpoint);
    return true;
  }
  std::error_code ec;
  std::filesystem::remove(std::filesystem::path(dir) / checkpoint_file_name(), ec);
  return false;
}

}  // namespace pardel::app

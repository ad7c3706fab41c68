// Resolves models by name or compiles a .lag file into a cached shared object and loads it; the
// generator's warnings are kept with the cache entry and handed to callers by model_warnings.
#include "pardel/model_loader.hpp"

#include <dlfcn.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "pardel/pardel.hpp"

extern char** environ;

namespace pardel {
namespace {

namespace fs = std::filesystem;

bool looks_like_path(const std::string& s) {
  return s.find('/') != std::string::npos ||
         (s.size() > 4 && s.compare(s.size() - 4, 4, ".lag") == 0);
}

std::string read_file(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw ModelLoadError("'" + path.string() + "' is a directory, not a .lag file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ModelLoadError("cannot read model file '" + path.string() + "'");
  std::ostringstream buf;
  buf << in.rdbuf();
  return buf.str();
}

// FNV-1a, 64 bit: a stable key for the cache (std::hash is not stable across builds).
std::uint64_t fnv1a(const std::string& text, std::uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

fs::path cache_root() {
  if (const char* dir = std::getenv("PARDEL_CACHE_DIR"); dir && *dir) return dir;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return fs::path(xdg) / "pardel";
  if (const char* home = std::getenv("HOME"); home && *home) return fs::path(home) / ".cache" / "pardel";
  return fs::temp_directory_path() / ("pardel-cache-" + std::to_string(getuid()));
}

// Runs a program (no shell), its stdout and stderr appended to `log`; returns the exit status.
int run_program(const std::vector<std::string>& argv, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND,
                                   0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return 127;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return 127;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

#ifdef PARDEL_LOADER_GEN
// The toolchain in use (guarded by its mutex; read once per compile).
std::mutex toolchain_mutex;
LoaderToolchain& current_toolchain() {
  static LoaderToolchain toolchain{PARDEL_LOADER_GEN, PARDEL_LOADER_PYTHON, PARDEL_LOADER_RENDER, PARDEL_LOADER_CXX,
                                   PARDEL_LOADER_ABI_INCLUDE};
  return toolchain;
}

// Generates, renders and compiles `lag` into the cache folder `dir`; atomic: built in a
// temporary sibling folder and renamed into place.
void build_into(const fs::path& lag, const fs::path& dir, const LoaderToolchain& tools) {
  fs::create_directories(dir.parent_path());
  // Temporary folders of this entry left by compiles that were killed (their process is gone).
  const std::string prefix = dir.filename().string() + ".tmp.";
  std::error_code listing;
  for (fs::directory_iterator it(dir.parent_path(), listing); !listing && it != fs::directory_iterator();
       it.increment(listing)) {
    const std::string name = it->path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const long pid = std::atol(name.c_str() + prefix.size());
    if (pid > 0 && pid != getpid() && kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
      std::error_code ignored;
      fs::remove_all(it->path(), ignored);
    }
  }
  fs::path tmp = dir.parent_path() /
                 (dir.filename().string() + ".tmp." + std::to_string(getpid()) + "." +
                  std::to_string(reinterpret_cast<std::uintptr_t>(&dir) & 0xffff));
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  const fs::path log = tmp / "log.txt";
  const fs::path ir = tmp / "model.ir.json";
  // `what` heads the message, followed by the tool's output; a refusal of the generator is its
  // FILE:LINE:COL diagnostic alone.
  auto fail = [&](const std::string& what, bool details_only = false) {
    std::string details = fs::exists(log) ? trim(read_file(log)) : std::string();
    fs::remove_all(tmp);
    if (details.empty()) throw ModelLoadError(what);
    throw ModelLoadError(details_only ? details : what + ":\n" + details);
  };
  if (run_program({tools.generator, lag.string(), "-o", ir.string(), "--source-name",
                   lag.filename().string()},
                  log) != 0)
    fail("pardel-gen failed on " + lag.string(), true);
  // What the generator printed on success is its warnings; kept with the entry for every load.
  std::ofstream(tmp / "warnings.txt") << (fs::exists(log) ? trim(read_file(log)) : std::string());
  if (run_program({tools.python, tools.render_script, ir.string(), "--out-dir", tmp.string()},
                  log) != 0)
    fail("rendering the kernels of " + lag.string() + " failed");
  std::string model;
  for (const auto& entry : fs::directory_iterator(tmp)) {
    if (entry.path().extension() == ".cpp") model = entry.path().stem().string();
  }
  if (model.empty()) fail("the generator wrote no kernels for " + lag.string());
  if (run_program({tools.compiler, "-std=c++17", "-O2", "-fPIC", "-shared", "-Wl,-Bsymbolic",
                   "-I" + tools.abi_include, (tmp / (model + ".cpp")).string(), "-o", (tmp / "model.so").string()},
                  log) != 0)
    fail("compiling the kernels of " + lag.string() + " failed (" + tools.compiler + ")");
  std::ofstream(tmp / "model_name.txt") << model;
  std::error_code ec;
  fs::rename(tmp, dir, ec);
  if (ec) fs::remove_all(tmp);  // another process finished first; its result is identical
}
#endif

/**
 * The generator's warnings kept with the cache entry `dir`: warnings.txt, or, in an entry written
 * before it was kept, the generator's diagnostics at the head of log.txt (each "...: warning:
 * model '...'" line with the source line and caret under it).
 */
std::string cached_warnings(const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir / "warnings.txt", ec)) return trim(read_file(dir / "warnings.txt"));
  if (!fs::exists(dir / "log.txt", ec)) return {};
  std::istringstream log(read_file(dir / "log.txt"));
  std::string line, out;
  bool inside = false;
  while (std::getline(log, line)) {
    if (line.find(": warning: model '") != std::string::npos) {
      inside = true;
    } else if (!inside || line.empty() || line[0] != ' ') {
      inside = false;
      continue;
    }
    out += line + "\n";
  }
  return trim(out);
}

/**
 * `warnings` with the file of each of the generator's diagnostics ("FILE:LINE:COL: warning: model
 * ...") replaced by `path`: one cache entry serves every copy of the same text, and its warnings
 * name the file it was first compiled from.
 */
std::string relocated(const std::string& warnings, const std::string& path) {
  std::istringstream in(warnings);
  std::string line, out;
  while (std::getline(in, line)) {
    const std::size_t w = line.find(": warning: model '");
    if (w != std::string::npos) {
      std::size_t p = w;  // back over ":LINE:COL" to the colon after FILE
      int colons = 0;
      while (p > 0) {
        const char c = line[p - 1];
        if (c == ':') {
          if (++colons == 2) {
            --p;
            break;
          }
        } else if (c < '0' || c > '9') {
          break;
        }
        --p;
      }
      if (colons == 2) line = path + line.substr(p);
    }
    out += line + "\n";
  }
  return trim(out);
}

std::mutex warnings_mutex;
std::map<const pardel_model*, std::string>& warnings_by_model() {
  static std::map<const pardel_model*, std::string> warnings;
  return warnings;
}

}  // namespace

std::string model_warnings(const pardel_model* model) {
  std::lock_guard<std::mutex> lock(warnings_mutex);
  const auto& warnings = warnings_by_model();
  const auto it = warnings.find(model);
  return it == warnings.end() ? std::string() : it->second;
}

LoaderToolchain loader_toolchain() {
#ifdef PARDEL_LOADER_GEN
  std::lock_guard<std::mutex> lock(toolchain_mutex);
  return current_toolchain();
#else
  return {};
#endif
}

void set_loader_toolchain(const LoaderToolchain& toolchain) {
#ifdef PARDEL_LOADER_GEN
  std::lock_guard<std::mutex> lock(toolchain_mutex);
  current_toolchain() = toolchain;
#else
  (void)toolchain;
#endif
}

bool can_compile_lag_files() {
#ifdef PARDEL_LOADER_GEN
  const LoaderToolchain tools = loader_toolchain();
  return fs::exists(tools.generator) && fs::exists(tools.render_script);
#else
  return false;
#endif
}

const pardel_model* resolve_model(const std::string& name_or_path) {
  if (!looks_like_path(name_or_path)) {
    if (const pardel_model* model = find_model(name_or_path)) return model;
    std::string known;
    for (const pardel_model* m : bundled_models()) known += std::string(known.empty() ? "" : ", ") + m->name;
    throw ModelLoadError("unknown model '" + name_or_path + "' (compiled models: " + known +
                         "; a path to a .lag file is compiled on the fly)");
  }
#ifndef PARDEL_LOADER_GEN
  throw ModelLoadError("cannot compile '" + name_or_path +
                       "': this build of pardel has no generator (GiNaC was not found)");
#else
  static std::mutex mutex;
  static std::map<std::uint64_t, const pardel_model*> loaded;
  std::lock_guard<std::mutex> lock(mutex);

  const fs::path lag = name_or_path;
  const std::string content = read_file(lag);
  std::uint64_t key = fnv1a(content);
  const LoaderToolchain tools = loader_toolchain();
  std::error_code time_error;
  const auto generator_time = fs::last_write_time(tools.generator, time_error);
  if (time_error)
    throw ModelLoadError("cannot compile '" + name_or_path + "': no generator at " + tools.generator);
  key = fnv1a(tools.generator, key);
  key = fnv1a(tools.compiler, key);
  key = fnv1a(std::to_string(generator_time.time_since_epoch().count()), key);
  if (auto it = loaded.find(key); it != loaded.end()) return it->second;

  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(key));
  const fs::path dir = cache_root() / hex;
  if (!fs::exists(dir / "model.so")) build_into(lag, dir, tools);

  // Loads the cache entry; on failure returns nullptr and says why.
  auto load = [&dir](std::string* why) -> const pardel_model* {
    std::ifstream name_file(dir / "model_name.txt");
    std::string model;
    std::getline(name_file, model);
    model = trim(model);
    if (model.empty()) {
      *why = "the cache entry " + dir.string() + " has no model name";
      return nullptr;
    }
    void* handle = dlopen((dir / "model.so").c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      *why = std::string("cannot load the compiled model: ") + dlerror();
      return nullptr;
    }
    auto* descriptor = static_cast<const pardel_model*>(dlsym(handle, (model + "_model").c_str()));
    if (!descriptor) {
      *why = "the compiled model " + (dir / "model.so").string() + " has no symbol " + model + "_model";
      return nullptr;
    }
    if (descriptor->abi_version != PARDEL_KERNEL_ABI_VERSION) {
      *why = "the compiled model " + (dir / "model.so").string() + " was built for another kernel ABI version";
      return nullptr;
    }
    return descriptor;
  };
  std::string why;
  const pardel_model* descriptor = load(&why);
  if (!descriptor) {
    // A damaged entry (a truncated or deleted file, edited by hand or left by a full disk) is
    // compiled again once rather than failing until the cache is cleared.
    std::error_code ec;
    fs::remove_all(dir, ec);
    build_into(lag, dir, tools);
    descriptor = load(&why);
    if (!descriptor) throw ModelLoadError(why);
  }
  {
    std::lock_guard<std::mutex> warnings_lock(warnings_mutex);
    warnings_by_model()[descriptor] = relocated(cached_warnings(dir), lag.string());
  }
  loaded.emplace(key, descriptor);
  return descriptor;
#endif
}

}  // namespace pardel

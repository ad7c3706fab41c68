// Resolves models by name or compiles a .lag file into a cached shared object and loads it; the
// generator's warnings are kept with the cache entry and handed to callers by model_warnings.
// The cache is private and its entries verified before they are loaded (model_cache.hpp); a bad
// entry is never loaded: it is compiled again, and the model's warnings say why.
#include "pardel/model_loader.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "model_cache.hpp"
#include "pardel/pardel.hpp"
#include "pardel/regular_file.hpp"

extern char** environ;

namespace pardel {
namespace {

namespace fs = std::filesystem;
using namespace model_cache;

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

// What set_compile_interrupt set (guarded by its mutex; read once per program).
std::mutex interrupt_mutex;
std::function<bool()>& compile_interrupt() {
  static std::function<bool()> stop;
  return stop;
}

/** run_program's status for a program stopped by the compile interrupt (set_compile_interrupt). */
constexpr int kStopped = -2;

// Runs a program (no shell), its stdout and stderr appended to `log`; returns the exit status, or
// kStopped where the compile interrupt asked to stop it. The program runs in a process group of
// its own, so that a Ctrl-C at the terminal (which signals the whole foreground group) reaches
// this process, which decides what an interruption does, and not the compiler in the middle of a
// cache entry; a stop ends the whole group.
int run_program(const std::vector<std::string>& argv, const fs::path& log) {
  std::function<bool()> stop;
  {
    std::lock_guard<std::mutex> lock(interrupt_mutex);
    stop = compile_interrupt();
  }
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND,
                                   0600);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  int rc = posix_spawn(&pid, args[0], &actions, &attributes, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  if (rc != 0) return 127;
  int status = 0;
  for (;;) {
    const pid_t done = waitpid(pid, &status, stop ? WNOHANG : 0);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) return 127;
    if (done == 0 && stop()) {
      ::kill(-pid, SIGTERM);  // the program's group: the compiler driver and what it started
      while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
      }
      return kStopped;
    }
    if (done == 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

#ifdef PARDEL_LOADER_GEN
/** run_program, throwing ModelLoadError where the compile interrupt stopped the program. */
int run_step(const std::vector<std::string>& argv, const fs::path& log, const fs::path& lag) {
  const int status = run_program(argv, log);
  if (status == kStopped) throw ModelLoadError("interrupted while compiling " + lag.string());
  return status;
}

// The toolchain in use (guarded by its mutex; read once per compile).
std::mutex toolchain_mutex;
LoaderToolchain& current_toolchain() {
  static LoaderToolchain toolchain{PARDEL_LOADER_GEN, PARDEL_LOADER_PYTHON, PARDEL_LOADER_RENDER, PARDEL_LOADER_CXX,
                                   PARDEL_LOADER_ABI_INCLUDE};
  return toolchain;
}

/** Removes a temporary folder when it goes out of scope, unless it was renamed into the cache. */
struct TemporaryFolder {
  fs::path path;
  bool kept = false;
  ~TemporaryFolder() {
    if (kept) return;
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
};

// Generates, renders and compiles `lag` into the cache folder `dir`; atomic: built in a private
// temporary sibling folder (ENTRY.tmp.HOST.PIDNS.PID.RANDOM), every file and the folder flushed to
// disk and every write checked, the SHA-256 digests of model.so, model_name.txt and warnings.txt
// recorded in sha256sums.txt, then renamed into place; on any failure (a full disk among them) the
// temporary folder is removed and no entry appears.
void build_into(const fs::path& lag, const fs::path& dir, const LoaderToolchain& tools) {
  const fs::path root = dir.parent_path();
  const ProcessTag me = this_process();
  // Temporary folders of this entry left by compiles that were killed.
  const std::string prefix = dir.filename().string() + ".tmp.";
  std::error_code listing;
  for (fs::directory_iterator it(root, listing); !listing && it != fs::directory_iterator(); it.increment(listing)) {
    const std::string name = it->path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    if (abandoned(it->path(), name.substr(prefix.size()), me)) {
      std::error_code ignored;
      fs::remove_all(it->path(), ignored);
    }
  }
  std::string name = (root / (prefix + me.host + "." + me.pidns + "." + std::to_string(me.pid) + ".XXXXXX")).string();
  if (!::mkdtemp(name.data()))  // mode 0700, a fresh random name
    throw ModelLoadError("cannot create a temporary folder in the model cache " + root.string() + ": " +
                         std::strerror(errno));
  TemporaryFolder folder{name};
  const fs::path tmp = folder.path;
  const fs::path log = tmp / "log.txt";
  const fs::path ir = tmp / "model.ir.json";
  // `what` heads the message, followed by the tool's output; a refusal of the generator is its
  // FILE:LINE:COL diagnostic alone.
  auto fail = [&](const std::string& what, bool details_only = false) {
    std::string details = fs::exists(log) ? trim(read_file(log)) : std::string();
    if (details.empty()) throw ModelLoadError(what);
    throw ModelLoadError(details_only ? details : what + ":\n" + details);
  };
  if (run_step({tools.generator, lag.string(), "-o", ir.string(), "--source-name",
                   lag.filename().string()},
                  log, lag) != 0)
    fail("pardel-gen failed on " + lag.string(), true);
  // What the generator printed on success is its warnings; kept with the entry for every load.
  const std::string warnings = fs::exists(log) ? trim(read_file(log)) : std::string();
  if (run_step({tools.python, tools.render_script, ir.string(), "--out-dir", tmp.string()}, log, lag) != 0)
    fail("rendering the kernels of " + lag.string() + " failed");
  std::string model;
  for (const auto& entry : fs::directory_iterator(tmp)) {
    if (entry.path().extension() == ".cpp") model = entry.path().stem().string();
  }
  if (model.empty()) fail("the generator wrote no kernels for " + lag.string());
  const fs::path so = tmp / "model.so";
  if (run_step({tools.compiler, "-std=c++17", "-O2", "-fPIC", "-shared", "-Wl,-Bsymbolic",
                   "-I" + tools.abi_include, (tmp / (model + ".cpp")).string(), "-o", so.string(),
                   "-lquadmath"},  // the extended-precision kernels (grad_extended) call libquadmath
               log, lag) != 0)
    fail("compiling the kernels of " + lag.string() + " failed (" + tools.compiler + ")");
  try {
    // model.so: this user's alone, its bytes on disk, its digest taken from what is on disk.
    std::string so_bytes;
    const int fd = ::open(so.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) throw ModelLoadError("cannot open " + so.string() + ": " + std::strerror(errno));
    int error = 0;
    if (::fchmod(fd, 0700) != 0 || ::fsync(fd) != 0 || !read_fd(fd, &so_bytes)) error = errno;
    ::close(fd);
    if (error) throw ModelLoadError("writing " + so.string() + " failed: " + std::strerror(error));
    write_private_file(tmp / "warnings.txt", warnings);
    write_private_file(tmp / "model_name.txt", model);
    write_private_file(tmp / "sha256sums.txt", sha256_hex(so_bytes) + "  model.so\n" + sha256_hex(model) +
                                                   "  model_name.txt\n" + sha256_hex(warnings) + "  warnings.txt\n");
    if (const std::string why = sync_folder(tmp); !why.empty())
      throw ModelLoadError("writing " + tmp.string() + " failed: " + why);
  } catch (const ModelLoadError& e) {
    throw ModelLoadError("writing the compiled model of " + lag.string() + " into the cache failed: " + e.what());
  }
  if (::rename(tmp.c_str(), dir.c_str()) == 0) {
    folder.kept = true;
    sync_folder(root);  // best effort: the entry is complete either way
  } else if (errno != EEXIST && errno != ENOTEMPTY) {
    throw ModelLoadError("cannot move the compiled model of " + lag.string() + " into the cache as " + dir.string() +
                         ": " + std::strerror(errno));
  }
  // else another process finished first; its result is identical, and ours is removed.
}
#endif

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

namespace {
std::mutex notice_mutex;
std::function<void(const std::string&)>& compile_notice() {
  static std::function<void(const std::string&)> notice;
  return notice;
}
}  // namespace

void set_compile_notice(std::function<void(const std::string& path)> notice) {
  std::lock_guard<std::mutex> lock(notice_mutex);
  compile_notice() = std::move(notice);
}

void set_compile_interrupt(std::function<bool()> stop) {
  std::lock_guard<std::mutex> lock(interrupt_mutex);
  compile_interrupt() = std::move(stop);
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

#ifdef PARDEL_LOADER_GEN
/** What a cache entry's code depends on besides the .lag text, the generator and the compiler: the
 *  render script, its templates and the kernel headers (ABI, condensation, extended precision),
 *  each as its path, size and modification time, so that a changed template or header compiles
 *  the model again instead of loading code that the old one wrote. */
static std::string toolchain_stamp(const LoaderToolchain& tools) {
  std::vector<fs::path> files{tools.render_script};
  const auto add_folder = [&files](const fs::path& dir) {
    std::error_code ec;
    for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
      if (it->is_regular_file(ec)) files.push_back(it->path());
  };
  add_folder(fs::path(tools.render_script).parent_path() / "templates");
  add_folder(fs::path(tools.abi_include) / "pardel");
  std::sort(files.begin(), files.end());
  std::string stamp;
  for (const fs::path& file : files) {
    std::error_code size_error, time_error;
    const auto size = fs::file_size(file, size_error);
    const auto time = fs::last_write_time(file, time_error);
    stamp += file.string() + '\0' + (size_error ? "-" : std::to_string(size)) + '\0' +
             (time_error ? "-" : std::to_string(time.time_since_epoch().count())) + '\0';
  }
  return stamp;
}
#endif

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
  static std::map<std::string, const pardel_model*> loaded;
  std::lock_guard<std::mutex> lock(mutex);

  const fs::path lag = name_or_path;
  // A regular file of at most 1 MiB, as pardel-gen reads it (a FIFO, a device, a folder or a
  // sparse file of gigabytes is refused by name before a byte is read), located at 1:1 as there.
  std::string content;
  try {
    content = read_regular_file(lag.string(), FileLimits::lag, ".lag file");
  } catch (const FileError& error) {
    throw ModelLoadError(lag.string() + ":1:1: error: " + error.reason());
  }
  const LoaderToolchain tools = loader_toolchain();
  std::error_code time_error;
  const auto generator_time = fs::last_write_time(tools.generator, time_error);
  if (time_error)
    throw ModelLoadError("cannot compile '" + name_or_path + "': no generator at " + tools.generator);
  // The entry's name: a digest of the text, the generator (its path and time), the compiler, and
  // the render script, templates and kernel headers (toolchain_stamp).
  const std::string key = sha256_hex(content + '\0' + tools.generator + '\0' + tools.compiler + '\0' +
                                     std::to_string(generator_time.time_since_epoch().count()) + '\0' +
                                     toolchain_stamp(tools))
                              .substr(0, 32);
  if (auto it = loaded.find(key); it != loaded.end()) return it->second;

  const fs::path dir = cache_root() / key;
  std::string notice, why, entry_warnings;
  const pardel_model* descriptor = nullptr;
  for (int attempt = 0; !descriptor; ++attempt) {
    Entry entry;
    bool absent = false;
    why = open_entry(dir, &entry, &absent);
    if (why.empty() && (descriptor = load_entry(dir, entry, &why))) {
      entry_warnings = entry.warnings;
      break;
    }
    // Compiled once more when the entry is bad after a compile, or gone (another process removed it).
    if (attempt > 1 || (attempt == 1 && !absent))
      throw ModelLoadError("the model compiled from " + lag.string() + " into " + dir.string() +
                           " cannot be loaded: " + why);
    if (!absent) {
      // A damaged or altered entry (a truncated, patched, replaced or linked file, one others can
      // write) is never loaded: it is compiled again, and the caller is told why.
      if (notice.empty())
        notice = "warning: the cached model " + dir.string() + " was not loaded and is compiled again: " + why;
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
    {
      std::lock_guard<std::mutex> lock(notice_mutex);
      if (compile_notice()) compile_notice()(name_or_path);
    }
    build_into(lag, dir, tools);
  }
  std::string warnings = relocated(entry_warnings, lag.string());
  if (!notice.empty()) warnings = notice + (warnings.empty() ? "" : "\n" + warnings);
  {
    std::lock_guard<std::mutex> warnings_lock(warnings_mutex);
    warnings_by_model()[descriptor] = warnings;
  }
  loaded.emplace(key, descriptor);
  return descriptor;
#endif
}

}  // namespace pardel

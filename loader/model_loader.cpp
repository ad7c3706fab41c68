// Resolves models by name or compiles a .lag file into a cached shared object and loads it; the
// generator's warnings are kept with the cache entry and handed to callers by model_warnings.
// The cache is private: its folder and every entry must be this user's, writable by no one else
// and no symbolic link, or they are refused; each entry records the SHA-256 digests of its files
// when it is built and is verified against them before its shared object is loaded (through the
// descriptor that was verified). A bad entry is never loaded: it is compiled again, and the
// model's warnings say why.
#include "pardel/model_loader.hpp"

#include <dlfcn.h>
#include <fcntl.h>
#include <openssl/evp.h>
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
#include <vector>

#include "pardel/pardel.hpp"
#include "pardel/regular_file.hpp"

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

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

/** The SHA-256 digest of `bytes` in lower-case hexadecimal (OpenSSL's libcrypto). */
std::string sha256_hex(const std::string& bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &size, EVP_sha256(), nullptr) != 1)
    throw ModelLoadError("computing a SHA-256 digest failed (OpenSSL)");
  static const char hex[] = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < size; ++i) {
    out += hex[digest[i] >> 4];
    out += hex[digest[i] & 15];
  }
  return out;
}

/** Reads the rest of the open file `fd` into `out`; false (errno set) on a read error. */
bool read_fd(int fd, std::string* out) {
  out->clear();
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n == 0) return true;
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    out->append(buffer, static_cast<std::size_t>(n));
  }
}

/**
 * Why the object described by `st` (from lstat or fstat) is not private to this user, completing
 * "it is ...": a symbolic link, not a folder (`folder`) or not a regular file, owned by another user,
 * or writable by its group or by others; empty when it is private.
 */
std::string not_private(const struct stat& st, bool folder) {
  if (S_ISLNK(st.st_mode)) return "a symbolic link";
  if (folder && !S_ISDIR(st.st_mode)) return "not a folder";
  if (!folder && !S_ISREG(st.st_mode)) return "not a regular file";
  if (st.st_uid != ::geteuid())
    return "owned by user " + std::to_string(st.st_uid) + ", not by this user (" + std::to_string(::geteuid()) + ")";
  if (st.st_mode & (S_IWGRP | S_IWOTH)) {
    char mode[16];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    const char* who = (st.st_mode & S_IWGRP) && (st.st_mode & S_IWOTH) ? "its group and by others"
                      : (st.st_mode & S_IWGRP)                         ? "its group"
                                                                        : "others";
    return std::string("writable by ") + who + " (mode " + mode + ")";
  }
  return {};
}

/** This process's private cache folder, removed when the process ends (not by a forked child). */
struct ProcessCache {
  fs::path path;
  pid_t owner = 0;
  ~ProcessCache() {
    if (path.empty() || ::getpid() != owner) return;
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
};

/**
 * The cache when none of PARDEL_CACHE_DIR, XDG_CACHE_HOME and HOME is set (a service, a batch job):
 * a fresh folder of this process made by mkdtemp (mode 0700) in the temporary folder and removed at
 * exit, so nothing is reused between processes. Never a fixed path, which another user could create
 * first and fill.
 */
fs::path process_cache() {
  static ProcessCache cache;
  if (cache.path.empty()) {
    std::error_code ec;
    fs::path tmp = fs::temp_directory_path(ec);
    if (ec) tmp = "/tmp";
    std::string name = (tmp / "pardel-cache-XXXXXX").string();
    if (!::mkdtemp(name.data()))
      throw ModelLoadError("cannot create a private model cache folder in " + tmp.string() + ": " +
                           std::strerror(errno));
    cache.path = name;
    cache.owner = ::getpid();
  }
  return cache.path;
}

/**
 * The cache folder: $PARDEL_CACHE_DIR, else $XDG_CACHE_HOME/pardel, else $HOME/.cache/pardel, else a
 * private folder of this process; created with mode 0700 when missing. Refused, with the path and the
 * reason, unless it is a folder of this user's that no one else can write and not a symbolic link.
 */
fs::path cache_root() {
  std::string root, from;
  if (const char* dir = std::getenv("PARDEL_CACHE_DIR"); dir && *dir) {
    root = dir;
    from = "PARDEL_CACHE_DIR";
  } else if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) {
    root = (fs::path(xdg) / "pardel").string();
    from = "XDG_CACHE_HOME";
  } else if (const char* home = std::getenv("HOME"); home && *home) {
    root = (fs::path(home) / ".cache" / "pardel").string();
    from = "HOME";
  } else {
    root = process_cache().string();
    from = "a private folder of this process: no PARDEL_CACHE_DIR, XDG_CACHE_HOME or HOME";
  }
  while (root.size() > 1 && root.back() == '/') root.pop_back();  // else lstat would follow a link
  std::error_code ec;
  const fs::path parent = fs::path(root).parent_path();
  if (!parent.empty()) fs::create_directories(parent, ec);
  if (::mkdir(root.c_str(), 0700) != 0 && errno != EEXIST)
    throw ModelLoadError("cannot create the model cache folder " + root + " (" + from + "): " + std::strerror(errno));
  struct stat st;
  if (::lstat(root.c_str(), &st) != 0)
    throw ModelLoadError("cannot examine the model cache folder " + root + " (" + from + "): " + std::strerror(errno));
  if (const std::string why = not_private(st, true); !why.empty())
    throw ModelLoadError("refusing the model cache folder " + root + " (" + from + "): it is " + why +
                         "; a model cache must be a folder of this user's that no one else can write (chmod 700 "
                         "it, or set PARDEL_CACHE_DIR to another folder)");
  return root;
}

/**
 * Writes `text` to the new file `path` (mode 0600; an existing file or link there is an error) and
 * flushes it to disk; throws, naming the path and the reason, when any step fails (a full disk among
 * them). The caller removes the partial file with its temporary folder.
 */
void write_private_file(const fs::path& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) throw ModelLoadError("cannot create " + path.string() + ": " + std::strerror(errno));
  int error = 0;
  for (std::size_t done = 0; done < text.size() && !error;) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else if (n == 0) {
      error = EIO;
    } else if (errno != EINTR) {
      error = errno;
    }
  }
  if (!error && ::fsync(fd) != 0) error = errno;
  if (::close(fd) != 0 && !error) error = errno;
  if (error) throw ModelLoadError("writing " + path.string() + " failed: " + std::strerror(error));
}

/** Flushes the folder `path` (the names in it) to disk; the reason on failure, else "". */
std::string sync_folder(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return std::strerror(errno);
  const int rc = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  return rc == 0 ? std::string() : std::strerror(error);
}

// Runs a program (no shell), its stdout and stderr appended to `log`; returns the exit status.
int run_program(const std::vector<std::string>& argv, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND,
                                   0600);
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

/**
 * The name of the temporary folders of this process's compiles, after "ENTRY.tmp.": HOST.PIDNS.PID,
 * HOST being the host name with anything but letters, digits and '-' written '-', PIDNS the inode
 * number of the process's PID namespace (0 if unknown). Processes sharing one cache from different
 * hosts (a cache on NFS under mpirun) or PID namespaces (containers) differ in HOST or PIDNS even
 * where their PIDs are equal.
 */
struct ProcessTag {
  std::string host, pidns;
  long pid = 0;
};

ProcessTag this_process() {
  ProcessTag tag;
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  for (const char* c = host; *c && tag.host.size() < 64; ++c)
    tag.host += std::isalnum(static_cast<unsigned char>(*c)) || *c == '-' ? *c : '-';
  if (tag.host.empty()) tag.host = "unknown-host";
  char link[128];
  const ssize_t n = ::readlink("/proc/self/ns/pid", link, sizeof link - 1);  // "pid:[4026531836]"
  for (ssize_t i = 0; i < n; ++i)
    if (std::isdigit(static_cast<unsigned char>(link[i]))) tag.pidns += link[i];
  if (tag.pidns.empty()) tag.pidns = "0";
  tag.pid = static_cast<long>(::getpid());
  return tag;
}

/** How long a temporary folder of a compile that cannot be proven dead is left alone. */
constexpr std::chrono::hours kAbandonedAfter{24};

/**
 * Whether the temporary folder `path` (`rest` is its name after "ENTRY.tmp.") belongs to a compile
 * that can no longer finish: one of this host and PID namespace whose process is gone, or any other
 * (another host's, another namespace's, one named by an older pardel) untouched for a day. A compile
 * that may still run elsewhere is never removed earlier.
 */
bool abandoned(const fs::path& path, const std::string& rest, const ProcessTag& me) {
  std::vector<std::string> fields;
  std::stringstream in(rest);
  for (std::string f; std::getline(in, f, '.');) fields.push_back(f);
  if (fields.size() == 4 && fields[0] == me.host && fields[1] == me.pidns && me.pidns != "0") {
    char* end = nullptr;
    const long pid = std::strtol(fields[2].c_str(), &end, 10);
    if (end && *end == '\0' && pid > 0 && pid != me.pid && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH)
      return true;
  }
  struct stat st;
  if (::lstat(path.c_str(), &st) != 0) return false;
  return std::chrono::system_clock::now() - std::chrono::system_clock::from_time_t(st.st_mtime) > kAbandonedAfter;
}

#ifdef PARDEL_LOADER_GEN
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
  if (run_program({tools.generator, lag.string(), "-o", ir.string(), "--source-name",
                   lag.filename().string()},
                  log) != 0)
    fail("pardel-gen failed on " + lag.string(), true);
  // What the generator printed on success is its warnings; kept with the entry for every load.
  const std::string warnings = fs::exists(log) ? trim(read_file(log)) : std::string();
  if (run_program({tools.python, tools.render_script, ir.string(), "--out-dir", tmp.string()},
                  log) != 0)
    fail("rendering the kernels of " + lag.string() + " failed");
  std::string model;
  for (const auto& entry : fs::directory_iterator(tmp)) {
    if (entry.path().extension() == ".cpp") model = entry.path().stem().string();
  }
  if (model.empty()) fail("the generator wrote no kernels for " + lag.string());
  const fs::path so = tmp / "model.so";
  if (run_program({tools.compiler, "-std=c++17", "-O2", "-fPIC", "-shared", "-Wl,-Bsymbolic",
                   "-I" + tools.abi_include, (tmp / (model + ".cpp")).string(), "-o", so.string(),
                   "-lquadmath"},  // the extended-precision kernels (grad_extended) call libquadmath
                  log) != 0)
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

/** A verified cache entry: its model's name, the generator's warnings and model.so, open. */
struct Entry {
  std::string model, warnings;
  int so_fd = -1;
  Entry() = default;
  Entry(const Entry&) = delete;
  Entry& operator=(const Entry&) = delete;
  ~Entry() {
    if (so_fd >= 0) ::close(so_fd);
  }
};

/**
 * Opens the file `name` of the entry `dir` without following a symbolic link (nor blocking on a
 * FIFO) and reads it into `bytes`; returns "" or why it cannot be trusted: missing, a link, not a
 * regular file, another user's, writable by others. With `keep_fd` the open descriptor is kept there.
 */
std::string read_entry_file(const fs::path& dir, const std::string& name, std::string* bytes, int* keep_fd) {
  const fs::path path = dir / name;
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ELOOP) return name + " is a symbolic link";
    if (errno == ENOENT) return name + " is missing";
    return "cannot open " + name + ": " + std::strerror(errno);
  }
  struct stat st;
  std::string why;
  if (::fstat(fd, &st) != 0) {
    why = "cannot examine " + name + ": " + std::strerror(errno);
  } else if (const std::string bad = not_private(st, false); !bad.empty()) {
    why = name + " is " + bad;
  } else if (!read_fd(fd, bytes)) {
    why = "cannot read " + name + ": " + std::strerror(errno);
  }
  if (why.empty() && keep_fd) {
    *keep_fd = fd;
  } else {
    ::close(fd);
  }
  return why;
}

/**
 * Verifies the cache entry `dir` and opens it into `entry`: the folder this user's alone and no link,
 * and model.so, model_name.txt and warnings.txt regular files of this user's that no one else can
 * write, matching the SHA-256 digests recorded in sha256sums.txt when the entry was built. Returns
 * "" when it can be loaded, else why not (`absent` set when there is no entry at all).
 */
std::string open_entry(const fs::path& dir, Entry* entry, bool* absent) {
  *absent = false;
  struct stat st;
  if (::lstat(dir.c_str(), &st) != 0) {
    *absent = errno == ENOENT;
    return *absent ? "the entry is missing" : std::string("cannot examine the entry: ") + std::strerror(errno);
  }
  if (const std::string bad = not_private(st, true); !bad.empty()) return "the entry is " + bad;
  std::string sums;
  if (std::string why = read_entry_file(dir, "sha256sums.txt", &sums, nullptr); !why.empty())
    return why + (why == "sha256sums.txt is missing" ? " (no digests were recorded)" : "");
  std::map<std::string, std::string> recorded;
  std::istringstream lines(sums);
  for (std::string line; std::getline(lines, line);) {
    const std::size_t gap = line.find("  ");
    if (gap != std::string::npos) recorded[line.substr(gap + 2)] = line.substr(0, gap);
  }
  std::string model_name, warnings, so_bytes;
  const std::pair<const char*, std::string*> files[] = {
      {"model.so", &so_bytes}, {"model_name.txt", &model_name}, {"warnings.txt", &warnings}};
  for (const auto& [name, bytes] : files) {
    const bool so = std::strcmp(name, "model.so") == 0;
    if (std::string why = read_entry_file(dir, name, bytes, so ? &entry->so_fd : nullptr); !why.empty()) return why;
    const auto it = recorded.find(name);
    if (it == recorded.end()) return std::string("sha256sums.txt records no digest of ") + name;
    if (sha256_hex(*bytes) != it->second)
      return std::string(name) + " does not match the SHA-256 digest recorded when the entry was built";
  }
  entry->model = trim(model_name);
  entry->warnings = trim(warnings);
  if (entry->model.empty()) return "model_name.txt is empty";
  return {};
}

/**
 * dlopens the verified entry's model.so through its open descriptor (/proc/self/fd/N), so that the
 * file loaded is the file verified; returns its descriptor, or nullptr and why not. Once loaded, the
 * descriptor stays open for the life of the process: the dynamic loader knows the library by that
 * name, and a later model opened under a reused descriptor number would be taken for it.
 */
const pardel_model* load_entry(const fs::path& dir, Entry& entry, std::string* why) {
  std::string path = "/proc/self/fd/" + std::to_string(entry.so_fd);
  if (::access(path.c_str(), F_OK) != 0) path = (dir / "model.so").string();  // no /proc: the checked path
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    *why = "cannot load the compiled model " + (dir / "model.so").string() + ": " + dlerror();
    return nullptr;
  }
  entry.so_fd = -1;  // kept open (see above)
  auto* descriptor = static_cast<const pardel_model*>(dlsym(handle, (entry.model + "_model").c_str()));
  if (!descriptor) {
    *why = "the compiled model " + (dir / "model.so").string() + " has no symbol " + entry.model + "_model";
    return nullptr;
  }
  if (descriptor->abi_version != PARDEL_KERNEL_ABI_VERSION) {
    *why = "the compiled model " + (dir / "model.so").string() + " was built for another kernel ABI version";
    return nullptr;
  }
  return descriptor;
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

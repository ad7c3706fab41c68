// The private model cache of the run-time model loader (see model_cache.hpp): where it is, the
// checks that keep it this user's alone, files written privately, and its entries verified against
// their recorded SHA-256 digests before their shared object is loaded through the verified
// descriptor.
#include "model_cache.hpp"

#include <dlfcn.h>
#include <fcntl.h>
#include <openssl/evp.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "pardel/model_loader.hpp"

namespace pardel::model_cache {

namespace {

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

}  // namespace

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

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

namespace {

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
 * Why a folder above the cache (`st` from stat: a link is judged by what it leads to) would let
 * another user replace the cache folder, completing "it is ...": owned by a user other than this
 * one and root, or writable by its group or by others without the sticky bit (which /tmp has);
 * empty when it is safe.
 */
std::string unsafe_above(const struct stat& st) {
  if (st.st_uid != ::geteuid() && st.st_uid != 0)
    return "owned by user " + std::to_string(st.st_uid) + ", neither this user (" + std::to_string(::geteuid()) +
           ") nor root";
  if ((st.st_mode & (S_IWGRP | S_IWOTH)) && !(st.st_mode & S_ISVTX)) {
    char mode[16];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return std::string("writable by ") + ((st.st_mode & S_IWOTH) ? "others" : "its group") +
           " without the sticky bit (mode " + mode + ")";
  }
  return {};
}

}  // namespace

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
  // Whoever can write a folder above it can rename the cache away and put another in its place.
  for (fs::path above = fs::absolute(root, ec).parent_path(); !above.empty(); above = above.parent_path()) {
    struct stat up;
    if (::stat(above.c_str(), &up) == 0)
      if (const std::string why = unsafe_above(up); !why.empty())
        throw ModelLoadError("refusing the model cache folder " + root + " (" + from + "): the folder " +
                             above.string() + " above it is " + why +
                             ", so another user could replace the cache; set PARDEL_CACHE_DIR to a folder under "
                             "folders of this user's or root's");
    if (above == above.root_path()) break;
  }
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

std::string sync_folder(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return std::strerror(errno);
  const int rc = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  return rc == 0 ? std::string() : std::strerror(error);
}

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

namespace {

/** How long a temporary folder of a compile that cannot be proven dead is left alone. */
constexpr std::chrono::hours kAbandonedAfter{24};

}  // namespace

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

namespace {

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

}  // namespace

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

}  // namespace pardel::model_cache

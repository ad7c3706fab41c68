/**
 * @file model_cache.hpp
 * Internal to the run-time model loader: its private cache of compiled .lag models. The cache
 * folder and every entry must be this user's, writable by no one else and no symbolic link, or they
 * are refused; files are written privately and flushed; an entry records the SHA-256 digests of its
 * files when it is built and is verified against them before its shared object is loaded through
 * the descriptor that was verified.
 */
#ifndef PARDEL_LOADER_MODEL_CACHE_HPP
#define PARDEL_LOADER_MODEL_CACHE_HPP

#include <unistd.h>

#include <filesystem>
#include <string>

#include "pardel/kernel_abi.h"

namespace pardel::model_cache {

namespace fs = std::filesystem;

/** `s` without trailing newlines and spaces. */
std::string trim(std::string s);

/** The SHA-256 digest of `bytes` in lower-case hexadecimal (OpenSSL's libcrypto). */
std::string sha256_hex(const std::string& bytes);

/** Reads the rest of the open file `fd` into `out`; false (errno set) on a read error. */
bool read_fd(int fd, std::string* out);

/**
 * The cache folder: $PARDEL_CACHE_DIR, else $XDG_CACHE_HOME/pardel, else $HOME/.cache/pardel, else a
 * private folder of this process; created with mode 0700 when missing. Refused, with the path and the
 * reason, unless it is a folder of this user's that no one else can write and not a symbolic link.
 */
fs::path cache_root();

/**
 * Writes `text` to the new file `path` (mode 0600; an existing file or link there is an error) and
 * flushes it to disk; throws, naming the path and the reason, when any step fails (a full disk among
 * them). The caller removes the partial file with its temporary folder.
 */
void write_private_file(const fs::path& path, const std::string& text);

/** Flushes the folder `path` (the names in it) to disk; the reason on failure, else "". */
std::string sync_folder(const fs::path& path);

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

/** This process's tag. */
ProcessTag this_process();

/**
 * Whether the temporary folder `path` (`rest` is its name after "ENTRY.tmp.") belongs to a compile
 * that can no longer finish: one of this host and PID namespace whose process is gone, or any other
 * (another host's, another namespace's, one named by an older pardel) untouched for a day. A compile
 * that may still run elsewhere is never removed earlier.
 */
bool abandoned(const fs::path& path, const std::string& rest, const ProcessTag& me);

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
 * Verifies the cache entry `dir` and opens it into `entry`: the folder this user's alone and no link,
 * and model.so, model_name.txt and warnings.txt regular files of this user's that no one else can
 * write, matching the SHA-256 digests recorded in sha256sums.txt when the entry was built. Returns
 * "" when it can be loaded, else why not (`absent` set when there is no entry at all).
 */
std::string open_entry(const fs::path& dir, Entry* entry, bool* absent);

/**
 * dlopens the verified entry's model.so through its open descriptor (/proc/self/fd/N), so that the
 * file loaded is the file verified; returns its descriptor, or nullptr and why not. Once loaded, the
 * descriptor stays open for the life of the process: the dynamic loader knows the library by that
 * name, and a later model opened under a reused descriptor number would be taken for it.
 */
const pardel_model* load_entry(const fs::path& dir, Entry& entry, std::string* why);

}  // namespace pardel::model_cache

#endif  // PARDEL_LOADER_MODEL_CACHE_HPP

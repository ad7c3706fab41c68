/**
 * @file regular_file.hpp
 * Opening a file named by a user: every reader of pardel (scenes, sweep files, .lag files,
 * trajectory and guess CSV files, checkpoints; pardel-gen, the model loader, pardel::app, the
 * Python module) goes through open_regular_file or read_regular_file, so that a FIFO, a device, a
 * folder or a file larger than the reader's limit is refused by name before a byte is read: the
 * file is opened with O_NONBLOCK (a FIFO without a writer does not block the open), the opened
 * descriptor is checked with fstat (it must be a regular file of at most `limit` bytes) and only
 * then read, so the check and the read concern the same file. Header-only, POSIX.
 */
#ifndef PARDEL_REGULAR_FILE_HPP
#define PARDEL_REGULAR_FILE_HPP

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

namespace pardel {

/** The largest file each reader accepts, in bytes (docs/reliability.md, "Guarantees"). */
struct FileLimits {
  static constexpr std::uint64_t lag = std::uint64_t{1} << 20;          ///< .lag model files: 1 MiB
  static constexpr std::uint64_t scene = std::uint64_t{16} << 20;       ///< scene files: 16 MiB
  static constexpr std::uint64_t sweep = std::uint64_t{16} << 20;       ///< sweep files: 16 MiB
  static constexpr std::uint64_t trajectory = std::uint64_t{512} << 20; ///< trajectory / guess CSV: 512 MiB
  static constexpr std::uint64_t checkpoint = std::uint64_t{2} << 30;   ///< checkpoint.json: 2 GiB
};

/** A file that cannot be read as a regular file of bounded size; what() is "PATH: error: REASON". */
class FileError : public std::runtime_error {
 public:
  FileError(const std::string& path, const std::string& reason)
      : std::runtime_error(path + ": error: " + reason), path_(path), reason_(reason) {}
  const std::string& path() const { return path_; }
  const std::string& reason() const { return reason_; }  ///< e.g. "is a FIFO, not a regular file"

 private:
  std::string path_, reason_;
};

namespace detail {

/** "is a directory, not a WHAT", "is a FIFO, not a regular file", ... for a file of type `mode`. */
inline std::string not_regular_reason(mode_t mode, const std::string& what) {
  if (S_ISDIR(mode)) return "is a directory, not a " + what;
  if (S_ISFIFO(mode)) return "is a FIFO, not a regular file";
  if (S_ISCHR(mode)) return "is a character device, not a regular file";
  if (S_ISBLK(mode)) return "is a block device, not a regular file";
  if (S_ISSOCK(mode)) return "is a socket, not a regular file";
  return "is not a regular file";
}

/** "N bytes" with the binary unit when it is a whole number of them (1 MiB). */
inline std::string byte_count(std::uint64_t n) {
  const std::string text = std::to_string(n) + " bytes";
  const std::uint64_t gib = std::uint64_t{1} << 30, mib = std::uint64_t{1} << 20;
  if (n >= gib && n % gib == 0) return text + " (" + std::to_string(n / gib) + " GiB)";
  if (n >= mib && n % mib == 0) return text + " (" + std::to_string(n / mib) + " MiB)";
  return text;
}

}  // namespace detail

/**
 * Opens `path` for reading and returns its descriptor (O_CLOEXEC; the caller closes it), after
 * checking on the opened descriptor that it is a regular file of at most `limit` bytes (its size in
 * `*size` when given). `what` names the file for messages ("scene file"). Throws FileError:
 * "cannot open WHAT: <system reason>", "is a directory, not a WHAT", "is a FIFO, not a regular
 * file" (a character device, a block device, a socket), "is N bytes, more than the limit of M
 * bytes for a WHAT".
 */
inline int open_regular_file(const std::string& path, std::uint64_t limit, const std::string& what,
                             std::uint64_t* size = nullptr) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    struct stat st {};
    // A socket cannot be opened (ENXIO): say what it is rather than "No such device or address".
    if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
      throw FileError(path, detail::not_regular_reason(st.st_mode, what));
    throw FileError(path, "cannot open " + what + ": " + std::strerror(err));
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    throw FileError(path, "cannot read " + what + ": " + std::strerror(err));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    throw FileError(path, detail::not_regular_reason(st.st_mode, what));
  }
  const auto bytes = static_cast<std::uint64_t>(st.st_size);
  if (bytes > limit) {
    ::close(fd);
    throw FileError(path, "is " + detail::byte_count(bytes) + ", more than the limit of " +
                              detail::byte_count(limit) + " for a " + what);
  }
  // Reads of a regular file do not block; the flag is cleared all the same for plain semantics.
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  if (size) *size = bytes;
  return fd;
}

/**
 * Reads up to `capacity` bytes from `fd` into `buffer`; returns the count (0 at the end). Throws
 * FileError "cannot read WHAT: <reason>" naming `path`. Retries after EINTR.
 */
inline std::size_t read_some(int fd, char* buffer, std::size_t capacity, const std::string& path,
                             const std::string& what) {
  for (;;) {
    const ssize_t n = ::read(fd, buffer, capacity);
    if (n >= 0) return static_cast<std::size_t>(n);
    if (errno == EINTR) continue;
    throw FileError(path, "cannot read " + what + ": " + std::strerror(errno));
  }
}

/**
 * The bytes of `path`, a regular file of at most `limit` bytes (checked by open_regular_file
 * before reading, and again while reading: a file that grows past the limit, or one whose size
 * the system does not report, such as those of /proc, is cut off with an error). Throws FileError.
 */
inline std::string read_regular_file(const std::string& path, std::uint64_t limit, const std::string& what) {
  std::uint64_t size = 0;
  const int fd = open_regular_file(path, limit, what, &size);
  std::string text;
  try {
    text.reserve(static_cast<std::size_t>(size));
    char buffer[1 << 16];
    for (;;) {
      const std::size_t n = read_some(fd, buffer, sizeof buffer, path, what);
      if (n == 0) break;
      if (text.size() + n > limit)
        throw FileError(path, "grew past the limit of " + detail::byte_count(limit) + " for a " + what + " while read");
      text.append(buffer, n);
    }
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
  return text;
}

}  // namespace pardel

#endif  // PARDEL_REGULAR_FILE_HPP

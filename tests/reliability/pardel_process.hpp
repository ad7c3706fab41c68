/**
 * @file pardel_process.hpp
 * Test helper: runs the built `pardel` as a subprocess (fork + exec, no shell) with extra or removed
 * environment variables, its stdout and stderr in a log file, under a time limit after which it is
 * killed, so that a hang or a crash of pardel is a test failure rather than a stuck or dead test.
 */
#ifndef PARDEL_TESTS_RELIABILITY_PARDEL_PROCESS_HPP
#define PARDEL_TESTS_RELIABILITY_PARDEL_PROCESS_HPP

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace reliability {

namespace fs = std::filesystem;

inline std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

/** A finished run of pardel. */
struct Outcome {
  int status = -1;         ///< exit status, or 128 + the signal that ended it
  bool timed_out = false;  ///< killed by the helper after the time limit (a hang)
  std::string output;      ///< stdout and stderr together
};

/** Starts `program` with `args`; `env` entries are NAME=VALUE to set or -NAME to remove. */
inline pid_t start_program(const std::string& program, const std::vector<std::string>& args, const fs::path& log,
                           const std::vector<std::string>& env = {}) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  ::setpgid(0, 0);  // its own process group, so that a hang is ended with everything it started
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) ::_exit(126);
  ::dup2(fd, 1);
  ::dup2(fd, 2);
  ::close(fd);
  const int null_in = ::open("/dev/null", O_RDONLY);
  if (null_in >= 0) ::dup2(null_in, 0);
  for (const std::string& e : env) {
    if (!e.empty() && e[0] == '-') {
      ::unsetenv(e.c_str() + 1);
    } else {
      const auto eq = e.find('=');
      ::setenv(e.substr(0, eq).c_str(), e.substr(eq + 1).c_str(), 1);
    }
  }
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(program.c_str()));
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ::execv(program.c_str(), argv.data());
  ::_exit(127);
}

/** Starts pardel with `args`; `env` entries are NAME=VALUE to set or -NAME to remove. */
inline pid_t start_pardel(const std::vector<std::string>& args, const fs::path& log,
                          const std::vector<std::string>& env = {}) {
  return start_program(PARDEL_CLI_PATH, args, log, env);
}

/** Waits for a started program, killing it and its process group (SIGKILL) after `limit_s` seconds. */
inline Outcome finish_pardel(pid_t pid, const fs::path& log, int limit_s = 60) {
  Outcome o;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(limit_s);
  int wstatus = 0;
  for (;;) {
    const pid_t r = ::waitpid(pid, &wstatus, WNOHANG);
    if (r == pid) break;
    if (r < 0) return o;
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(-pid, SIGKILL);
      ::waitpid(pid, &wstatus, 0);
      o.timed_out = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  o.status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
  o.output = read_text(log);
  return o;
}

inline Outcome run_pardel(const std::vector<std::string>& args, const fs::path& log,
                          const std::vector<std::string>& env = {}, int limit_s = 60) {
  return finish_pardel(start_pardel(args, log, env), log, limit_s);
}

/** Files named NAME.tmp.* (left-over temporary files) directly inside `dir`. */
inline std::vector<std::string> temporary_files(const fs::path& dir) {
  std::vector<std::string> found;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.find(".tmp.") != std::string::npos) found.push_back(name);
  }
  return found;
}

/** A fresh, empty scratch folder under the system's temporary folder. */
inline fs::path scratch_folder(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

}  // namespace reliability

#endif  // PARDEL_TESTS_RELIABILITY_PARDEL_PROCESS_HPP

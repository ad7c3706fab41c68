// Runs the plotting scripts of the command line in a child process (see plot_runner.hpp).
#include "plot_runner.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

#include "pardel_cli/config.hpp"

extern char** environ;

namespace pardel::cli {

bool run_plot_script(const std::string& script, const std::string& out_dir, const std::string& what) {
  std::vector<std::string> argv_strings = {config::python, script, out_dir};
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int spawn_error = ::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ);
  if (spawn_error != 0) {
    std::fprintf(stderr, "warning: %s not written: cannot run %s: %s\n", what.c_str(), config::python,
                 std::strerror(spawn_error));
    return false;
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      std::fprintf(stderr, "warning: %s not written: waitpid failed: %s\n", what.c_str(), std::strerror(errno));
      return false;
    }
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::fprintf(stderr, "warning: %s not written: %s %s exited with status %d\n", what.c_str(), config::python,
                 script.c_str(), WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    return false;
  }
  return true;
}

}  // namespace pardel::cli

// Runs the plotting scripts of the command line in a child process (see plot_runner.hpp).
#include "plot_runner.hpp"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

#include "pardel_cli/config.hpp"
#include "signals.hpp"

extern char** environ;

namespace pardel::cli {

bool run_plot_script(const std::string& script, const std::string& out_dir, const std::string& what) {
  std::vector<std::string> argv_strings = {config::python, script, out_dir};
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  // A signal that ends pardel during the plot step ends the script too (it would write pictures
  // into the folder after pardel has gone, beside a later solve's outputs), then pardel.
  int stopped_by = 0;
  CatchSignals catch_signals;
  const int spawn_error = ::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ);
  if (spawn_error != 0) {
    std::fprintf(stderr, "warning: %s not written: cannot run %s: %s\n", what.c_str(), config::python,
                 std::strerror(spawn_error));
    return false;
  }
  int status = 0;
  for (;;) {  // polled, so that a signal that came before the wait is seen as well
    if (caught_signal() != 0 && stopped_by == 0) {
      stopped_by = caught_signal();
      ::kill(pid, SIGTERM);
    }
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) {
      std::fprintf(stderr, "warning: %s not written: waitpid failed: %s\n", what.c_str(), std::strerror(errno));
      return false;
    }
    if (done == 0) ::usleep(10000);
  }
  const bool killed = stopped_by != 0;
  if (caught_signal() != 0 && stopped_by == 0) stopped_by = caught_signal();  // after the script had ended
  if (stopped_by != 0) {
    if (killed)
      std::fprintf(stderr, "warning: %s not written: stopped by %s\n", what.c_str(),
                   stopped_by == SIGTERM ? "SIGTERM" : "SIGINT");
    ::signal(stopped_by, SIG_DFL);  // the signal's usual effect on pardel, once the script has ended
    ::raise(stopped_by);
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::fprintf(stderr, "warning: %s not written: %s %s exited with status %d\n", what.c_str(), config::python,
                 script.c_str(), WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    return false;
  }
  return true;
}

}  // namespace pardel::cli

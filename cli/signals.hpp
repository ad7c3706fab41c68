// SIGINT and SIGTERM as a record that the command line polls: the one place pardel's commands catch
// them (a model's compile, a solve, a sweep, the plot step).
#pragma once

#include <atomic>
#include <csignal>
#include <string>

namespace pardel::cli {

/** From construction until restore() (or destruction) SIGINT and SIGTERM do not end pardel: the
 *  first one is recorded (caught_signal, interrupted) for the command to poll. Construction clears
 *  the record, so that a scope sees only its own signals (the plot step after an interrupted solve
 *  runs); restore() puts the previous actions back and, where no signal came, the record of the
 *  scope outside. */
class CatchSignals {
 public:
  /** What the signal caught does when it comes again: nothing more (recorded), or its usual
   *  effect (ends_process, SA_RESETHAND): a second Ctrl-C ends at once a command that polls only
   *  between long steps. */
  enum class Again { recorded, ends_process };
  explicit CatchSignals(Again again = Again::recorded);
  CatchSignals(const CatchSignals&) = delete;
  CatchSignals& operator=(const CatchSignals&) = delete;
  ~CatchSignals() { restore(); }
  void restore();

 private:
  struct sigaction previous_int_ {}, previous_term_ {};
  int outer_signal_ = 0;
  bool installed_ = true;
};

/** True once the latest CatchSignals caught a signal (read from any thread; a sweep's stop flag). */
const std::atomic<bool>& interrupted();
/** The signal the latest CatchSignals caught first: SIGINT, SIGTERM, or 0. */
int caught_signal();
/** "SIGINT (Ctrl-C)", "SIGTERM", or "" for 0. */
std::string signal_name(int signal);

}  // namespace pardel::cli

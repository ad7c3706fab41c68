// The command line's record of SIGINT and SIGTERM (see signals.hpp).
#include "signals.hpp"

namespace pardel::cli {

namespace {

std::atomic<bool> g_interrupted{false};
std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free,
              "set from a signal handler");

extern "C" void on_caught_signal(int signal) {
  int none = 0;
  g_signal.compare_exchange_strong(none, signal);  // the first one counts
  g_interrupted.store(true);
}

}  // namespace

CatchSignals::CatchSignals(Again again) : outer_signal_(g_signal.exchange(0)) {
  g_interrupted.store(false);
  struct sigaction record {};
  record.sa_handler = on_caught_signal;
  sigemptyset(&record.sa_mask);
  record.sa_flags = SA_RESTART | (again == Again::ends_process ? SA_RESETHAND : 0);
  ::sigaction(SIGINT, &record, &previous_int_);
  ::sigaction(SIGTERM, &record, &previous_term_);
}

void CatchSignals::restore() {
  if (!installed_) return;
  installed_ = false;
  ::sigaction(SIGINT, &previous_int_, nullptr);
  ::sigaction(SIGTERM, &previous_term_, nullptr);
  if (g_signal.load() == 0 && outer_signal_ != 0) {
    g_signal.store(outer_signal_);
    g_interrupted.store(true);
  }
}

const std::atomic<bool>& interrupted() { return g_interrupted; }

int caught_signal() { return g_signal.load(); }

std::string signal_name(int signal) {
  return signal == SIGINT ? "SIGINT (Ctrl-C)" : signal == SIGTERM ? "SIGTERM" : "";
}

}  // namespace pardel::cli

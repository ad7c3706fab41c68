// The \r-updated progress line of `pardel solve` (see progress.hpp).
#include "progress.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>

namespace pardel::cli {

double contraction_rate(const IterationRecord& from, const IterationRecord& to) {
  const double steps = static_cast<double>(to.iteration - from.iteration);
  if (!(steps > 0) || !(from.residual > 0) || !(to.residual > 0) || from.N != to.N) return std::nan("");
  return std::pow(to.residual / from.residual, 1.0 / steps);
}

double eta_seconds(const IterationRecord& from, const IterationRecord& to, double tol) {
  const double rate = contraction_rate(from, to);
  if (!(rate > 0 && rate < 1)) return std::nan("");
  if (to.residual <= tol) return 0;
  const double iterations_left = std::log(tol / to.residual) / std::log(rate);
  const double seconds_per_iteration =
      (to.seconds - from.seconds) / static_cast<double>(to.iteration - from.iteration);
  return iterations_left * seconds_per_iteration;
}

ProgressLine::ProgressLine(bool enabled, double tol) : active_(enabled && ::isatty(STDERR_FILENO)), tol_(tol) {}

void ProgressLine::update(const IterationRecord& record) {
  if (!active_) return;
  const auto now = std::chrono::steady_clock::now();
  if (drawn_ && now - last_draw_ < std::chrono::milliseconds(200)) return;
  std::string line = fmt::format("iteration {:>9}  N {:>7}  residual {:10.3e}", record.iteration, record.N,
                                 record.residual);
  if (have_anchor_) {
    const double rate = contraction_rate(anchor_, record);
    if (std::isfinite(rate)) line += fmt::format("  rate {:.6f}/it", rate);
    const double eta = eta_seconds(anchor_, record, tol_);
    if (std::isfinite(eta)) line += fmt::format("  ETA {:.1f} s", eta);
  }
  std::fprintf(stderr, "\r%-100s", line.c_str());
  std::fflush(stderr);
  drawn_ = true;
  last_draw_ = now;
  anchor_ = record;
  have_anchor_ = true;
}

void ProgressLine::finish() {
  if (!drawn_) return;
  std::fprintf(stderr, "\r%-100s\r", "");
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace pardel::cli

/**
 * @file progress.hpp
 * The progress line of `pardel solve`: on a terminal, one \r-updated line (at most ~5 per second)
 * with the iteration, the residual, its contraction rate per iteration and an estimate of the
 * time left to reach the tolerance; silent when stderr is not a terminal or when disabled.
 */
#ifndef PARDEL_CLI_PROGRESS_HPP
#define PARDEL_CLI_PROGRESS_HPP

#include <chrono>
#include <string>

#include "pardel/pardel.hpp"

namespace pardel::cli {

class ProgressLine {
 public:
  /** `enabled` is false for --quiet; the line is shown only if stderr is also a terminal. */
  ProgressLine(bool enabled, double tol);
  /** Records one iteration; redraws when 0.2 s have passed since the last redraw. */
  void update(const IterationRecord& record);
  /** Clears the line (call before printing anything else). */
  void finish();

 private:
  bool active_ = false;
  bool drawn_ = false;
  double tol_ = 0;
  std::chrono::steady_clock::time_point last_draw_{};
  IterationRecord anchor_{};  ///< the record of the previous redraw, for the rate
  bool have_anchor_ = false;
};

/** The contraction factor per iteration between two records (residual ratio ^ 1/iterations),
 *  or NaN when it cannot be estimated. */
double contraction_rate(const IterationRecord& from, const IterationRecord& to);

/** Seconds left to reach `tol` at that rate and speed, or NaN when the rate is not below 1. */
double eta_seconds(const IterationRecord& from, const IterationRecord& to, double tol);

}  // namespace pardel::cli

#endif  // PARDEL_CLI_PROGRESS_HPP

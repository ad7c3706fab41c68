/**
 * @file exit_codes.hpp
 * The exit status of `pardel solve` for each way a solve ends, and of the command line's errors.
 */
#ifndef PARDEL_CLI_EXIT_CODES_HPP
#define PARDEL_CLI_EXIT_CODES_HPP

#include "pardel/pardel.hpp"

namespace pardel::cli {

/** An internal error, e.g. an output file that cannot be written. */
constexpr int kExitInternal = 1;
/** Invalid input: a bad scene, option or model. */
constexpr int kExitUsage = 2;

/** The exit status of `pardel solve` for a termination: 0 converged, 2 invalid_input,
 *  3 max_iterations, 4 diverged, 5 non_finite, 6 interrupted, 7 stalled (tol below round-off). */
inline int exit_code(Termination termination) {
  switch (termination) {
    case Termination::converged: return 0;
    case Termination::invalid_input: return kExitUsage;
    case Termination::max_iterations: return 3;
    case Termination::diverged: return 4;
    case Termination::non_finite: return 5;
    case Termination::interrupted: return 6;
    case Termination::stalled: return 7;
  }
  return kExitInternal;
}

}  // namespace pardel::cli

#endif  // PARDEL_CLI_EXIT_CODES_HPP

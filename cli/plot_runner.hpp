/**
 * @file plot_runner.hpp
 * The plots of the command line: runs a plotting script (cli/plot.py, plot_sweep.py)
 * with the configured Python on an output folder.
 */
#ifndef PARDEL_CLI_PLOT_RUNNER_HPP
#define PARDEL_CLI_PLOT_RUNNER_HPP

#include <string>

namespace pardel::cli {

/**
 * Runs `script` with the configured Python on an output folder. A plot is optional: on failure it
 * warns "warning: WHAT not written: ..." on stderr and returns false.
 */
bool run_plot_script(const std::string& script, const std::string& out_dir, const std::string& what);

}  // namespace pardel::cli

#endif  // PARDEL_CLI_PLOT_RUNNER_HPP

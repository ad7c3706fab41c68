/**
 * @file inspect_commands.hpp
 * The subcommands of the pardel command line that inspect models: `pardel models` (the bundled
 * models, as text or JSON) and `pardel kernels` (one interval's discrete Lagrangian and its
 * derivatives at given points, as JSON).
 */
#ifndef PARDEL_CLI_INSPECT_COMMANDS_HPP
#define PARDEL_CLI_INSPECT_COMMANDS_HPP

#include <string>
#include <vector>

#include "pardel/app/scene.hpp"

namespace pardel::cli {

/** Prints the bundled models; returns the exit code. */
int run_models(bool json);

/** The options of `pardel kernels`, as given on the command line. */
struct KernelArgs {
  std::string model, disc, h, t0, t1, q0, q1;
  std::vector<std::string> params;  ///< NAME=VALUE
};

/** Prints the kernels' values as JSON, the model from `resolve` (a bundled name or a .lag path);
 *  UsageError for a bad option value. */
int run_kernels(const KernelArgs& args, const app::ModelResolver& resolve);

}  // namespace pardel::cli

#endif  // PARDEL_CLI_INSPECT_COMMANDS_HPP

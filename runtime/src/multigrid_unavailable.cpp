/**
 * @file multigrid_unavailable.cpp
 * Stands in for runtime/src/multigrid.cpp in builds without it: Method::multigrid is then an
 * invalid_input with a message saying so.
 */
#include "engine.hpp"

namespace pardel::detail {

std::unique_ptr<Method_> make_multigrid(const Options&, int, std::string* message) {
  if (message)
    *message = "solver.method = multigrid is not available: the nonlinear multigrid (FAS) was measured and lost to "
               "newton on the fuel example (docs/benchmarks.md, Multigrid), so it is not built; use auto or newton";
  return nullptr;
}

}  // namespace pardel::detail

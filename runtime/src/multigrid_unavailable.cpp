/**
 * @file multigrid_unavailable.cpp
 * Stands in for runtime/src/multigrid.cpp in builds without it: Method::multigrid is then an
 * invalid_input with a message saying so.
 */
#include "engine.hpp"

namespace pardel::detail {

std::unique_ptr<Method_> make_multigrid(const Options&, int, std::string* message) {
  if (message) *message = "method 'multigrid' is not available in this build (runtime/src/multigrid.cpp is absent)";
  return nullptr;
}

}  // namespace pardel::detail

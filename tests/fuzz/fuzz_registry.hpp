/**
 * @file fuzz_registry.hpp
 * What the scene, sweep and --set fuzz entries share: the model registry they read against (the
 * bundled models only; a .lag path is refused rather than compiled) and a line count for checking
 * that a diagnostic's position lies inside the input.
 */
#ifndef PARDEL_TESTS_FUZZ_REGISTRY_HPP
#define PARDEL_TESTS_FUZZ_REGISTRY_HPP

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "pardel/pardel.hpp"

namespace pardel_fuzz {

/** Lines of `text` (1 + the number of newlines). */
inline std::size_t count_lines(const std::string& text) {
  std::size_t lines = 1;
  for (char c : text) lines += c == '\n';
  return lines;
}

/** The scene readers' model resolver: a bundled model by name; .lag paths throw. */
inline const pardel_model* resolve(const std::string& name) {
  if (name.find('/') != std::string::npos || (name.size() > 4 && name.compare(name.size() - 4, 4, ".lag") == 0)) {
    throw std::runtime_error("the fuzzing registry compiles no .lag files");
  }
  return pardel::find_model(name);
}

}  // namespace pardel_fuzz

#endif  // PARDEL_TESTS_FUZZ_REGISTRY_HPP

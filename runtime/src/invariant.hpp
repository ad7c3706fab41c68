/**
 * @file invariant.hpp
 * Internal: PARDEL_INVARIANT(condition, what) states an invariant of the runtime's own code, never
 * a check of a user's input (bad input gets an error message and a status). It is checked in
 * debug builds (NDEBUG not defined) and where PARDEL_CHECK_INVARIANTS is defined (the sanitizer
 * job of tools/ci/sanitizers.sh); a failure prints the file, the line, the condition and `what`,
 * and aborts. Elsewhere it compiles to nothing and its arguments are not evaluated.
 */
#ifndef PARDEL_RUNTIME_INVARIANT_HPP
#define PARDEL_RUNTIME_INVARIANT_HPP

#if !defined(NDEBUG) || defined(PARDEL_CHECK_INVARIANTS)
#include <cstdio>
#include <cstdlib>

namespace pardel::detail {

[[noreturn]] inline void invariant_failed(const char* file, int line, const char* condition, const char* what) {
  std::fprintf(stderr, "pardel: internal error at %s:%d: %s (%s does not hold)\n", file, line, what, condition);
  std::abort();
}

}  // namespace pardel::detail

#define PARDEL_INVARIANT(condition, what) \
  ((condition) ? static_cast<void>(0) : ::pardel::detail::invariant_failed(__FILE__, __LINE__, #condition, what))
#else
#define PARDEL_INVARIANT(condition, what) static_cast<void>(0)
#endif

#endif  // PARDEL_RUNTIME_INVARIANT_HPP

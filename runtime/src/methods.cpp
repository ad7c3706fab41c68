// The catalogue of solver methods (methods.hpp): one row per method.
#include "methods.hpp"

#include <algorithm>
#include <iterator>

#include "engine.hpp"
#include "topology.hpp"

namespace pardel::detail {
namespace {

std::unique_ptr<Method_> jacobi(const Options& options, int dim, Topology&, std::string*) {
  return make_jacobi(options, dim);
}
std::unique_ptr<Method_> jacobi_newton(const Options& options, int dim, Topology&, std::string*) {
  return make_jacobi_newton(options, dim);
}
std::unique_ptr<Method_> newton(const Options& options, int dim, Topology& topology, std::string*) {
  return topology.make_newton(options, dim);
}
std::unique_ptr<Method_> hybrid(const Options& options, int dim, Topology& topology, std::string*) {
  return make_hybrid(options, dim, topology, topology.make_newton(options, dim));
}
std::unique_ptr<Method_> stationary_newton(const Options& options, int dim, Topology& topology, std::string* why) {
  std::unique_ptr<Method_> method = topology.make_stationary_newton(options, dim);
  if (!method && why) *why = "stationary-newton does not run over this topology";
  return method;
}

/** Jacobi and Jacobi-Newton keep one status byte per node. */
double node_status_bytes(double N, int, bool) { return N + 1; }
/** The hybrid's Jacobi-Newton status, and its Newton (whose Hessian its check factors). */
double hybrid_bytes(double N, int d, bool cyclic) { return (N + 1) + newton_bytes(N, d, cyclic); }
/** Newton's arrays with the block LDL^T (stationary Newton has no cyclic reduction) and the pivot
 *  inverses of its indefinite factorization. */
double stationary_newton_bytes(double N, int d, bool) {
  return newton_bytes(N, d, false) + std::max(N - 1, 0.0) * d * d * 8;
}

// "auto" builds Newton: the solve runs its grid sequencing and, for a model without a declared
// cost, a second attempt with stationary-newton (solve.cpp); the levels see it as newton
// (levels.cpp), so its own row is not marked a whole-system Newton.
constexpr MethodRow kRows[] = {
    {Method::automatic, "auto", false, newton, newton_bytes},
    {Method::jacobi, "jacobi", false, jacobi, node_status_bytes},
    {Method::jacobi_newton, "jacobi-newton", false, jacobi_newton, node_status_bytes},
    {Method::newton, "newton", true, newton, newton_bytes},
    {Method::hybrid, "hybrid", false, hybrid, hybrid_bytes},
    {Method::stationary_newton, "stationary-newton", true, stationary_newton, stationary_newton_bytes},
};

}  // namespace

const MethodRow* method_row(Method method) {
  for (const MethodRow& row : kRows)
    if (row.method == method) return &row;
  return nullptr;
}

const MethodRow* method_row(const std::string& name) {
  for (const MethodRow& row : kRows)
    if (name == row.name) return &row;
  return nullptr;
}

const MethodRow* method_rows_begin() { return std::begin(kRows); }
const MethodRow* method_rows_end() { return std::end(kRows); }

}  // namespace pardel::detail

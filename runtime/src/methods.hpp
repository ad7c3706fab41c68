/**
 * @file methods.hpp
 * The catalogue of solver methods: one row per method with everything the rest of pardel asks of
 * it — its name in scenes, whether it is a whole-system Newton (grid sequencing solves each coarse
 * level to the tolerance), how it is built over a topology, and what its own arrays cost in
 * memory. A new method is one class (engine.hpp's Method_) plus one row here (methods.cpp).
 */
#ifndef PARDEL_RUNTIME_METHODS_HPP
#define PARDEL_RUNTIME_METHODS_HPP

#include <memory>
#include <string>

#include "pardel/pardel.hpp"

namespace pardel::detail {

class Method_;
class Topology;

/** One solver method. */
struct MethodRow {
  Method method;
  const char* name;  ///< as scenes, --set and Python name it
  /** Newton on the whole DEL system (minimizing or stationary): nested iteration solves each
   *  coarse level to the tolerance, and each level takes a step before it stops. */
  bool whole_system_newton;
  /** Builds the method over `topology`; nullptr with `*why` set where the topology cannot run it. */
  std::unique_ptr<Method_> (*make)(const Options& options, int dim, Topology& topology, std::string* why);
  /** The bytes of the method's own arrays at N intervals of dimension d (memory.hpp's estimate);
   *  `cyclic`: linear_solver = cyclic_reduction. */
  double (*bytes)(double N, int d, bool cyclic);
};

/** The row of `method`, nullptr for a value outside the catalogue. */
const MethodRow* method_row(Method method);
/** The row named `name`, nullptr for none. */
const MethodRow* method_row(const std::string& name);
/** The catalogue, in the order its names are listed in messages. */
const MethodRow* method_rows_begin();
const MethodRow* method_rows_end();

/** Newton's own arrays (newton.cpp): four vectors (right-hand side, step and two of the secular
 *  iteration) and the Hessian (memory.cpp); not TrialEvaluation's second set of interval arrays,
 *  which a level takes only from its first refused step on. */
double newton_bytes(double N, int d, bool cyclic);
/** The bytes of a BlockTridiagonal Hessian and its factors at N intervals (memory.cpp). */
double block_tridiagonal_bytes(double N, int d, bool cyclic);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_METHODS_HPP

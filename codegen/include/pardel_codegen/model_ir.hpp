/**
 * @file model_ir.hpp
 * The intermediate description (IR) of a model's generated code: for every discretization and
 * kernel variant (full, sweep, grad, action) and for the clock, the CSE'd straight-line code.
 * Written as JSON by pardel-gen and rendered to C++ by codegen/render.py (format: codegen/README.md).
 */
#ifndef PARDEL_CODEGEN_MODEL_IR_HPP
#define PARDEL_CODEGEN_MODEL_IR_HPP

#include <optional>
#include <string>
#include <vector>

#include "pardel_codegen/cse.hpp"
#include "pardel_codegen/lag_model.hpp"

namespace pardel_codegen {

/** The version of pardel-gen, written into every banner and IR. */
const char* generator_version();

/** The kernel variants of a discretization, in IR order. */
const std::vector<std::string>& kernel_variants();

/** One generated function. */
struct KernelIR {
  std::string variant;   ///< "full", "sweep", "grad", "action" or "clock"
  std::string function;  ///< the C symbol: `<model>_<disc-ident>_<variant>`, or `<model>_clock`
  std::vector<std::string> unused_inputs;  ///< kernel arguments the code never reads
  KernelCode code;
};

struct DiscretizationIR {
  DiscretizationSpec spec;
  /** In kernel_variants() order. For a discretization with interior values (interior_dim > 0)
   *  these are the entry points of the ABI, whose code (empty here) condenses the interval
   *  kernels below (pardel/condensation.hpp). */
  std::vector<KernelIR> kernels;
  int interior_dim = 0;  ///< interior values of one interval (interior points * ncoords)
  /** With interior values z: "start" (z's starting values), "interior" (dS/dz and d2S/dz2),
   *  "ext_grad" (S and its gradient in [q0, z, q1]) and "ext_full" (with the Hessian). */
  std::vector<KernelIR> interval_kernels;
  /** With interior values: "interior_extended", "ext_grad_extended" and, for models of order >= 2,
   *  "ext_full_extended", the interval kernels' code printed for extended precision (pd_quad in
   *  and out), which condensation.hpp's condensed_extended runs for grad_extended and
   *  full_extended. */
  std::vector<KernelIR> interval_extended;
  /** The grad kernel in extended precision (variant "grad_extended": Ld, D1, D2 in pd_quad from
   *  double inputs, written as double-double pairs; kernel_abi.h, pardel_extended_grad_kernel):
   *  without interior values its code printed for pd_quad, with them only its name (the code
   *  condenses interval_extended). */
  std::optional<KernelIR> extended;
  /** Models of order >= 2: the full kernel in extended precision (variant "full_extended": Ld,
   *  D1, D2, D11, D12, D22 as double-double pairs; kernel_abi.h, pardel_extended_full_kernel), for
   *  the corrections of iterative refinement where the Hessian rounded to double is too
   *  ill-conditioned (condition ~ N^(2 order)); as `extended` for interior values. */
  std::optional<KernelIR> extended_full;
  /** Models with a clock: the clock integrated over the interval with the discretization's own
   *  interpolant and quadrature (variant "travel", a pardel_action_kernel; kernel_abi.h,
   *  pardel_discretization::travel), the interval's share of the travel time under the
   *  free_final_time clock. With interior values only its name: its code solves for z
   *  (condensation.hpp) and calls travel_interval. */
  std::optional<KernelIR> travel;
  /** With interior values and `travel`: the integral over [q0, z, q1] (variant "travel_z"). */
  std::optional<KernelIR> travel_interval;
};

struct ModelIR {
  LagModel model;
  std::string source_name;
  std::vector<DiscretizationIR> discretizations;
  std::optional<KernelIR> clock;
};

/** Discretizes, differentiates and CSEs every kernel of `model`. @throws CodegenError */
ModelIR build_model_ir(const LagModel& model, const std::string& source_name,
                       const CseOptions& options = CseOptions());

/**
 * build_model_ir with its CodegenError (a constant that cannot be emitted as a double, such as
 * x^(10^308) differentiated or log(-1) = i pi) turned into a LagError at the .lag position that
 * causes it: the first power or function call (innermost first, LagModel::terms) whose value,
 * taken alone as the Lagrangian, fails the same way; else the start of the expression being
 * processed (L, or the clock when L alone builds). @throws LagError
 */
ModelIR build_model_ir_located(const LagModel& model, const std::string& source_name,
                               const CseOptions& options = CseOptions());

/** The IR as deterministic JSON text. */
std::string ir_to_json(const ModelIR& ir);

/** Operation counts per kernel before and after CSE: a text table, or JSON. */
std::string stats_table(const ModelIR& ir);
std::string stats_json(const ModelIR& ir);

}  // namespace pardel_codegen

#endif  // PARDEL_CODEGEN_MODEL_IR_HPP

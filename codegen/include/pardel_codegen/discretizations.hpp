/**
 * @file discretizations.hpp
 * The catalogue of discretizations: one row per family of discrete Lagrangians, with its name as
 * written in .lag files and scenes, its parameter (range and default), the model orders it is
 * valid for, its consistency order, the model orders it is the default of, and its builder (the
 * function that writes the interval's discrete Lagrangian). The .lag reader, its error messages,
 * the generator (discretize.cpp, model_ir.cpp) and the regularity check read it; adding a
 * discretization is one builder and one row (docs/architecture.md, "How to add a
 * discretization").
 */
#ifndef PARDEL_CODEGEN_DISCRETIZATIONS_HPP
#define PARDEL_CODEGEN_DISCRETIZATIONS_HPP

#include <ginac/ginac.h>

#include <string>
#include <vector>

#include "pardel_codegen/discretize.hpp"
#include "pardel_codegen/lag_model.hpp"

namespace pardel_codegen {

/** The largest number of quadrature points s a parameter s may ask for. */
constexpr int kMaxDiscretizationPoints = 16;

/** What a family's parameter is. */
enum class ParameterKind {
  none,      ///< the family takes no parameter
  rational,  ///< an exact rational, e.g. alpha of trapezoid (stored in DiscretizationSpec::alpha)
  integer,   ///< an integer such as s (stored in DiscretizationSpec::stages)
};

/** The parameter of a family, as written `NAME(KEY=VALUE)`. */
struct DiscretizationParameter {
  ParameterKind kind = ParameterKind::none;
  const char* key = "";          ///< "alpha", "s"
  const char* placeholder = "";  ///< the value in the list of valid names: "A" of "trapezoid(alpha=A)"
  const char* expected = "";     ///< what an unknown key is told to be: "s, the number of Gauss points"
  bool required = false;         ///< no default: the name must carry it
  const char* example = "";      ///< required: a value shown when it is missing ("4")
  const char* meaning = "";      ///< required: why it matters, shown when it is missing
  int default_value = 0;         ///< not required: the value of a bare name...
  bool default_is_order = false; ///< ...or, when set, the model's order
  /** Why `value` is not acceptable for an order-`order` model (reported at the value), or an empty
   *  string. `value` is what was written: any constant expression. */
  std::string (*refusal)(const std::string& name, const GiNaC::ex& value, int order) = nullptr;
};

/** Writes the interval's discrete Lagrangian L_d(h, t0, t1, q0, q1, p) of `spec` for `model`. */
using DiscreteLagrangianBuilder = GiNaC::ex (*)(const LagModel& model, const DiscretizationSpec& spec,
                                                const KernelSymbols& s, Gauss2Positions positions);

/** One family of discrete Lagrangians. A name may have several rows for disjoint model orders
 *  ("trapezoid": one for order 1, one with alpha for order 2). */
struct DiscretizationFamily {
  const char* name = "";            ///< as written in .lag files and scenes
  int min_order = 1, max_order = 0; ///< the model orders it is valid for (max_order 0: no bound)
  DiscretizationParameter parameter;
  /** The consistency order for an order-`order` model with integer parameter `s` (0 without one). */
  int (*consistency_order)(int order, int s) = nullptr;
  /** The model orders whose .lag without a `discretizations` line gets this family with its
   *  default parameter (default_min_order 0: none). */
  int default_min_order = 0, default_max_order = 0;
  /** Galerkin: s - order interior values per coordinate, under the rule `quadrature(s)`. */
  bool interior_values = false;
  Quadrature (*quadrature)(int s) = nullptr;
  DiscreteLagrangianBuilder build = nullptr;
  /** Why the discretization `spec` is not regular for any L (nullptr when it can be regular): the
   *  regularity check refuses it at its name unless the model allows singular equations. */
  const char* (*never_regular)(const DiscretizationSpec& spec) = nullptr;

  bool valid_for(int order) const { return order >= min_order && (max_order == 0 || order <= max_order); }
  bool default_for(int order) const {
    return default_min_order > 0 && order >= default_min_order && (default_max_order == 0 || order <= default_max_order);
  }
  /** "trapezoid", "trapezoid(alpha=A)", "hermite_gauss(s=S)": how the list of valid names shows it. */
  std::string shown() const;
};

/** Every family, in the order the lists of valid names show them. */
const std::vector<DiscretizationFamily>& discretization_catalogue();

/** The family called `name` that is valid for order-`order` models; nullptr when there is none. */
const DiscretizationFamily* find_discretization_family(const std::string& name, int order);

/** The first family called `name` that takes a parameter, whatever the order; nullptr when none does. */
const DiscretizationFamily* parameterized_discretization_family(const std::string& name);

/** True when some family, for some order, is called `name`. */
bool is_discretization_name(const std::string& name);

/** The valid names for order-`order` models, as error messages list them: "trapezoid, midpoint,
 *  hermite_gauss(s=S), galerkin_gauss(s=S), galerkin_lobatto(s=S)". */
std::string discretization_names(int order);

/** The spec of `family` for an order-`order` model with parameter `value` (ignored when the family
 *  takes none): canonical name and identifier, consistency order. @pre value is acceptable */
DiscretizationSpec make_discretization_spec(const DiscretizationFamily& family, int order, const GiNaC::numeric& value);

/** The parameter value of a bare name of `family` for an order-`order` model. @pre not required */
GiNaC::numeric default_parameter(const DiscretizationFamily& family, int order);

/** What a .lag without a `discretizations` line gets for an order-`order` model. */
DiscretizationSpec default_discretization(int order);

}  // namespace pardel_codegen

#endif  // PARDEL_CODEGEN_DISCRETIZATIONS_HPP

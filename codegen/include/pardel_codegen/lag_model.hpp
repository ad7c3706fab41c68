/**
 * @file lag_model.hpp
 * A parsed .lag model: its declarations as GiNaC symbols and expressions, and the
 * discretizations it asks for. Produced by parse_lag() (lag_parser.hpp).
 */
#ifndef PARDEL_CODEGEN_LAG_MODEL_HPP
#define PARDEL_CODEGEN_LAG_MODEL_HPP

#include <ginac/ginac.h>

#include <string>
#include <vector>

namespace pardel_codegen {

struct DiscretizationFamily;  // discretizations.hpp

/** One requested discretization with its canonical names. */
struct DiscretizationSpec {
  /** Its row of the catalogue (discretizations.hpp), which has static storage; see
   *  docs/discretizations.md for each family. */
  const DiscretizationFamily* family = nullptr;
  GiNaC::numeric alpha = 1;   ///< a rational parameter (alpha of trapezoid for order 2), exact
  int stages = 0;             ///< an integer parameter s: the Gauss points of hermite_gauss, s of the Galerkin family
  int interior_points = 0;    ///< interior values per coordinate of a Galerkin interval (s - order)
  std::string name;           ///< canonical name: "trapezoid", "trapezoid(alpha=1)", "hermite_gauss(s=3)", ...
  std::string ident;          ///< C-identifier form: "trapezoid", "trapezoid_alpha_1", "hermite_gauss_s_3", ...
  int consistency_order = 2;  ///< order of the discrete Lagrangian
  /** The family's name when a bare name means this spec for its model (a family without a
   *  parameter, or the parameter at its default: "hermite_gauss" of "hermite_gauss(s=3)" for an
   *  order-3 model, "trapezoid" of "trapezoid(alpha=1)" for order 2); empty otherwise. The
   *  generated model carries it (pardel_discretization::bare_name), so that the runtime resolves
   *  bare names as the reader does without a table of its own. */
  std::string bare_name;
};

/** A named run-time constant. */
struct ParamDecl {
  std::string name;
  double default_value = 0;
  GiNaC::symbol symbol;
};

/** Where a power or a function call of the model's text was read, and its value (so that an
 *  error found after parsing, such as a constant that cannot be emitted, can name a position). */
struct SourceTerm {
  int line = 0;
  int column = 0;
  GiNaC::ex value;
};

/** Everything a .lag file declares. */
struct LagModel {
  std::string name;
  int order = 1;                                   ///< gamma >= 1
  std::vector<std::string> coords;                 ///< coordinate names, in order
  /** coord_symbols[k][i] stands for the k-th derivative of coordinate i, k = 0..order. */
  std::vector<std::vector<GiNaC::symbol>> coord_symbols;
  std::vector<ParamDecl> params;                   ///< in declaration order
  GiNaC::symbol time{"t"};                         ///< the time t
  GiNaC::ex lagrangian;                            ///< L(t, q, q', ..., q^(order), params)
  bool has_clock = false;
  GiNaC::ex clock;                                 ///< dt/ds (derivatives up to order-1 only,
                                                   ///< or q' for order-1 models)
  std::vector<DiscretizationSpec> discretizations; ///< in the order asked for
  /** What the model's reported cost is called ("fuel", "travel_time"; empty when the .lag
   *  declares none) and how it is computed: "action" (the discrete action) or "clock" (the
   *  summed clock, the physical time). Declared by `cost NAME = action|clock`. */
  std::string cost_name;
  std::string cost_kind;
  int cost_line = 0;
  // Where things were read (diagnostics after parsing).
  std::string filename;                            ///< as given to parse_lag
  std::vector<std::string> source_lines;           ///< the text, line by line
  std::vector<SourceTerm> terms;                   ///< powers and calls of the lets, L and the
                                                   ///< clock, each after its operands
  int lagrangian_line = 0, lagrangian_column = 0;  ///< start of the expression of L
  int clock_line = 0, clock_column = 0;            ///< start of the clock's expression
  /** True when L or the clock depends on t. */
  bool time_dependent() const;
  int ncoords() const { return static_cast<int>(coords.size()); }
  int dim() const { return order * ncoords(); }
};

}  // namespace pardel_codegen

#endif  // PARDEL_CODEGEN_LAG_MODEL_HPP

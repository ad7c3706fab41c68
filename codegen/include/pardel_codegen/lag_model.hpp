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

/** The discrete Lagrangians pardel-gen knows (see docs/discretizations.md). */
enum class DiscretizationKind {
  trapezoid,        ///< order 1: h/2 [L(t0,q0,v) + L(t1,q1,v)], v = (q1-q0)/h
  midpoint,         ///< order 1: h L((t0+t1)/2, (q0+q1)/2, v)
  trapezoid_alpha,  ///< order 2: the seed's L_d^alpha family
  gauss2,           ///< order 2: 2-stage Gauss on the cubic Hermite interpolant
  hermite_gauss,    ///< any order: s-point Gauss-Legendre on the Hermite interpolant of degree 2*order-1
  galerkin_gauss,   ///< any order: Galerkin polynomial of degree s+order-1 (s-order interior values), s Gauss points
  galerkin_lobatto, ///< the same polynomial under the (s+1)-point Gauss-Lobatto rule
};

/** One requested discretization with its canonical names. */
struct DiscretizationSpec {
  DiscretizationKind kind = DiscretizationKind::trapezoid;
  GiNaC::numeric alpha = 1;   ///< the parameter of trapezoid_alpha (exact rational)
  int stages = 0;             ///< the number s of Gauss points of hermite_gauss; s of the Galerkin family
  int interior_points = 0;    ///< interior values per coordinate of a Galerkin interval (s - order)
  std::string name;           ///< canonical name: "trapezoid", "trapezoid(alpha=1)", "hermite_gauss(s=3)", ...
  std::string ident;          ///< C-identifier form: "trapezoid", "trapezoid_alpha_1", "hermite_gauss_s_3", ...
  int consistency_order = 2;  ///< order of the discrete Lagrangian
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

/**
 * @file discretize.hpp
 * Discrete Lagrangians of a LagModel as GiNaC expressions in the kernel inputs
 * (h, t0, t1, q0[0..m), q1[0..m), params), and the model's clock on one interval.
 * The formulas are documented in docs/discretizations.md.
 */
#ifndef PARDEL_CODEGEN_DISCRETIZE_HPP
#define PARDEL_CODEGEN_DISCRETIZE_HPP

#include <ginac/ginac.h>

#include <vector>

#include "pardel_codegen/lag_model.hpp"

namespace pardel_codegen {

/** The symbols of a kernel's inputs (see pardel/kernel_abi.h for the layout of q0 and q1). */
struct KernelSymbols {
  GiNaC::symbol h{"h"}, t0{"t0"}, t1{"t1"};
  std::vector<GiNaC::symbol> q0, q1;  ///< m = order * ncoords each: [coords, coords', ...]
  std::vector<GiNaC::symbol> p;       ///< the model's param symbols, in order
  explicit KernelSymbols(const LagModel& model);
};

/** Where the stage positions of gauss2 come from. */
enum class Gauss2Positions {
  hermite,  ///< the cubic Hermite interpolant at the Gauss points (what pardel-gen emits)
  seed,     ///< the seed's printed Q_i = linear interpolation - h/12 (v1 - v0)
};

/** Gauss-Legendre nodes and weights on [0, 1]: exact radicals for s <= 5, numbers of at least
 *  50 digits for larger s. Nodes ascending; the weights sum to 1. @pre 1 <= s */
struct Quadrature {
  std::vector<GiNaC::ex> nodes, weights;
};
Quadrature gauss_legendre(int s);

/** Gauss-Lobatto nodes and weights on [0, 1] with `points` nodes, both ends included, as numbers
 *  of at least 50 digits. Nodes ascending; the weights sum to 1. @pre 2 <= points */
Quadrature gauss_lobatto(int points);

/**
 * The two-point Hermite basis of degree 2*order - 1 on [0, 1] in the variable `u`: at[k] and
 * bt[k] (k < order) have k-th derivative 1 at u = 0 and at u = 1 respectively, and every other
 * derivative below `order` zero at both ends, so x(t0 + u h) = sum_k h^k (at[k] x0^(k) + bt[k] x1^(k)).
 */
struct HermiteBasis {
  std::vector<GiNaC::ex> at, bt;
};
HermiteBasis hermite_basis(int order, const GiNaC::symbol& u);

/**
 * One interval of a Galerkin discretization (galerkin_gauss, galerkin_lobatto): the polynomial
 * of degree s + order - 1 that takes both nodes' jets, written as their Hermite interpolant plus
 * spec.interior_points interior coefficients per coordinate times bubbles (polynomials that
 * vanish with their first order - 1 derivatives at both ends, with orthogonal order-th
 * derivatives), its action under the quadrature, and where the interior values start (zero: the
 * Hermite interpolant). The discrete Lagrangian is the action made stationary in the interior
 * values; the generated kernels find them by Newton's method and condense them out
 * (pardel/condensation.hpp).
 */
struct GalerkinInterval {
  std::vector<GiNaC::symbol> z;     ///< interior values, z[j * ncoords + i]: coordinate i, bubble j
  GiNaC::ex action;                 ///< h sum_i w_i L(t_i, x(c_i), ..., x^(order)(c_i)) in h, t0, t1, q0, q1, z, p
  std::vector<GiNaC::ex> start;     ///< z's starting values in h, q0, q1 (z's layout)
};
GalerkinInterval galerkin_interval(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s);

/** The discrete Lagrangian L_d(h, t0, t1, q0, q1, p) of `spec` for `model`: the builder of its
 *  row of the catalogue (discretizations.hpp). A Galerkin discretization with interior values has
 *  no closed form: use galerkin_interval. @throws std::logic_error for one. */
GiNaC::ex discrete_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                              Gauss2Positions positions = Gauss2Positions::hermite);

// The builders of the catalogue's rows (discretizations.cpp), one per family; each writes the
// interval's discrete Lagrangian (formulas: docs/discretizations.md). `positions` is read by
// gauss2 only.

/** Order 1: h/2 [L(t0, q0, v) + L(t1, q1, v)], v = (q1 - q0)/h. */
GiNaC::ex trapezoid_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                               Gauss2Positions positions);
/** Order 1: h L((t0 + t1)/2, (q0 + q1)/2, v). */
GiNaC::ex midpoint_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                              Gauss2Positions positions);
/** Order 2: the trapezoid rule with the accelerations of the L_d^alpha family (spec.alpha). */
GiNaC::ex trapezoid_alpha_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                                     Gauss2Positions positions);
/** Order 2: 2-stage Gauss on the cubic Hermite interpolant of (q0, v0, q1, v1). */
GiNaC::ex gauss2_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                            Gauss2Positions positions);
/** Any order: spec.stages-point Gauss-Legendre on the Hermite interpolant of degree 2 order - 1. */
GiNaC::ex hermite_gauss_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                                   Gauss2Positions positions);
/** galerkin_gauss and galerkin_lobatto without interior values (s = order): galerkin_interval's
 *  action. @throws std::logic_error with interior values. */
GiNaC::ex galerkin_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                              Gauss2Positions positions);

/** h * clock at (t0, q0, v) with v = (q1 - q0)/h for order 1, or q0's stored derivatives otherwise. */
GiNaC::ex interval_clock(const LagModel& model, const KernelSymbols& s);

}  // namespace pardel_codegen

#endif  // PARDEL_CODEGEN_DISCRETIZE_HPP

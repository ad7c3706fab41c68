/**
 * @file discretize.cpp
 * The discrete Lagrangians: substitution of interpolated stage values into the continuous L
 * and quadrature. Order 1: trapezoid and midpoint; order 2: the seed's trapezoid(alpha) family
 * and 2-stage Gauss on the cubic Hermite interpolant of (q0, v0, q1, v1); any order: s-point
 * Gauss-Legendre on the Hermite interpolant of degree 2 order - 1 of the two nodes' jets, and the
 * Galerkin family: a polynomial with interior values under Gauss or Gauss-Lobatto quadrature.
 * Each family's builder is named by its row of the catalogue (discretizations.cpp).
 */
#include "pardel_codegen/discretize.hpp"

#include "pardel_codegen/discretizations.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace pardel_codegen {
namespace {

using GiNaC::ex;
using GiNaC::exmap;

/** L evaluated at time `time` with values[k][i] substituted for the k-th derivative of coord i. */
ex evaluate_at(const LagModel& model, const ex& expr, const ex& time, const std::vector<std::vector<ex>>& values) {
  exmap m;
  m[model.time] = time;
  for (std::size_t k = 0; k < values.size(); ++k) {
    for (std::size_t i = 0; i < values[k].size(); ++i) m[model.coord_symbols[k][i]] = values[k][i];
  }
  return expr.subs(m, GiNaC::subs_options::no_pattern);
}

std::vector<ex> block(const std::vector<GiNaC::symbol>& q, std::size_t k, std::size_t n) {
  std::vector<ex> out;
  for (std::size_t i = 0; i < n; ++i) out.push_back(q[k * n + i]);
  return out;
}

/** Legendre polynomial P_s and its derivative at x (three-term recurrence). */
void legendre(int s, const GiNaC::numeric& x, GiNaC::numeric* p, GiNaC::numeric* dp) {
  GiNaC::numeric p0 = 1, p1 = x;
  for (int k = 2; k <= s; ++k) {
    GiNaC::numeric p2 = (GiNaC::numeric(2 * k - 1) * x * p1 - GiNaC::numeric(k - 1) * p0) / GiNaC::numeric(k);
    p0 = p1;
    p1 = p2;
  }
  *p = s == 0 ? GiNaC::numeric(1) : p1;
  *dp = GiNaC::numeric(s) * (x * p1 - p0) / (x * x - 1);
}

}  // namespace

Quadrature gauss_legendre(int s) {
  using GiNaC::numeric;
  // Nodes x and weights w on [-1, 1] for x >= 0 (mirrored below), then mapped to [0, 1]. Square
  // roots of an ex stay exact (GiNaC's sqrt of a numeric is a float of the current Digits), so that
  // the extended-precision kernels get the rule's exact constants.
  std::vector<ex> x, w;
  switch (s) {
    case 1: x = {0}; w = {2}; break;
    case 2: x = {GiNaC::sqrt(ex(3)) / 3}; w = {1}; break;
    case 3: x = {0, GiNaC::sqrt(ex(numeric(3, 5)))}; w = {numeric(8, 9), numeric(5, 9)}; break;
    case 4: {
      const ex r = 2 * GiNaC::sqrt(ex(numeric(6, 5))) / 7;
      x = {GiNaC::sqrt(numeric(3, 7) - r), GiNaC::sqrt(numeric(3, 7) + r)};
      w = {(18 + GiNaC::sqrt(ex(30))) / 36, (18 - GiNaC::sqrt(ex(30))) / 36};
      break;
    }
    case 5: {
      const ex r = 2 * GiNaC::sqrt(ex(numeric(10, 7)));
      x = {0, GiNaC::sqrt(5 - r) / 3, GiNaC::sqrt(5 + r) / 3};
      w = {numeric(128, 225), (322 + 13 * GiNaC::sqrt(ex(70))) / 900, (322 - 13 * GiNaC::sqrt(ex(70))) / 900};
      break;
    }
    default: {
      // Newton's method on P_s from Chebyshev-like starting points, at 60 digits.
      const long saved = GiNaC::Digits;
      GiNaC::Digits = std::max<long>(saved, 60);
      const numeric eps = GiNaC::ex_to<numeric>(GiNaC::pow(numeric(10), -55).evalf());
      for (int i = (s + 1) / 2; i >= 1; --i) {
        numeric xi = GiNaC::ex_to<numeric>(ex(std::cos(M_PI * (i - 0.25) / (s + 0.5))).evalf());
        numeric p, dp;
        for (int it = 0; it < 100; ++it) {
          legendre(s, xi, &p, &dp);
          const numeric step = p / dp;
          xi -= step;
          if (GiNaC::abs(step) < eps) break;
        }
        legendre(s, xi, &p, &dp);
        if (s % 2 == 1 && i == (s + 1) / 2) xi = 0;
        x.push_back(xi);
        w.push_back(2 / ((1 - xi * xi) * dp * dp));
      }
      GiNaC::Digits = saved;
      break;
    }
  }
  Quadrature q;
  for (std::size_t i = x.size(); i-- > 0;) {  // negative nodes, ascending
    if (x[i].is_zero()) continue;
    q.nodes.push_back((1 - x[i]) / 2);
    q.weights.push_back(w[i] / 2);
  }
  for (std::size_t i = 0; i < x.size(); ++i) {
    q.nodes.push_back((1 + x[i]) / 2);
    q.weights.push_back(w[i] / 2);
  }
  return q;
}

Quadrature gauss_lobatto(int points) {
  using GiNaC::numeric;
  // Interior nodes on [-1, 1]: the roots of P'_k, k = points - 1, by Newton's method from the
  // Chebyshev-Gauss-Lobatto points; (1 - x^2) P_k'' = 2 x P_k' - k (k + 1) P_k. Weights
  // 2 / (k (k + 1) P_k(x)^2).
  const int k = points - 1;
  const long saved = GiNaC::Digits;
  GiNaC::Digits = std::max<long>(saved, 60);
  const numeric eps = GiNaC::ex_to<numeric>(GiNaC::pow(numeric(10), -55).evalf());
  const numeric kk1(k * (k + 1));
  std::vector<numeric> x{-1};
  std::vector<numeric> w{numeric(2) / kk1};
  for (int i = k - 1; i >= 1; --i) {
    numeric xi = GiNaC::ex_to<numeric>(ex(std::cos(M_PI * i / k)).evalf());
    numeric p, dp;
    for (int it = 0; it < 100; ++it) {
      legendre(k, xi, &p, &dp);
      const numeric ddp = (2 * xi * dp - kk1 * p) / (1 - xi * xi);
      const numeric step = dp / ddp;
      xi -= step;
      if (GiNaC::abs(step) < eps) break;
    }
    if (k % 2 == 0 && 2 * i == k) xi = 0;
    legendre(k, xi, &p, &dp);
    x.push_back(xi);
    w.push_back(2 / (kk1 * p * p));
  }
  x.push_back(1);
  w.push_back(numeric(2) / kk1);
  Quadrature q;
  for (std::size_t i = 0; i < x.size(); ++i) {
    q.nodes.push_back(((1 + x[i]) / 2).evalf());
    q.weights.push_back((w[i] / 2).evalf());
  }
  q.nodes.front() = 0;
  q.nodes.back() = 1;
  GiNaC::Digits = saved;
  return q;
}

HermiteBasis hermite_basis(int order, const GiNaC::symbol& u) {
  // at[k] = u^k / k! (1 - u)^order sum_{m < order - k} binom(order - 1 + m, m) u^m, bt[k] = (-1)^k at[k](1 - u).
  HermiteBasis b;
  for (int k = 0; k < order; ++k) {
    ex sum = 0;
    for (int m = 0; m < order - k; ++m) sum += GiNaC::binomial(GiNaC::numeric(order - 1 + m), GiNaC::numeric(m)) * GiNaC::pow(u, m);
    const ex a = GiNaC::pow(u, k) / GiNaC::factorial(k) * GiNaC::pow(1 - u, order) * sum;
    b.at.push_back(a.expand());
    b.bt.push_back((GiNaC::pow(-1, k) * a.subs(u == 1 - u)).expand());
  }
  return b;
}

namespace {

/** A 60-digit number, with values below 1e-45 (round-off of exact zeros) set to 0. */
GiNaC::numeric cleaned(const GiNaC::numeric& v) {
  const GiNaC::numeric tiny = GiNaC::ex_to<GiNaC::numeric>(GiNaC::pow(GiNaC::numeric(10), -45).evalf());
  return GiNaC::abs(v) < tiny ? GiNaC::numeric(0) : v;
}

/** The value at u = c of the j-th u-derivative of the polynomial p(u). */
GiNaC::numeric derivative_at(const ex& p, const GiNaC::symbol& u, int j, const GiNaC::numeric& c) {
  return cleaned(GiNaC::ex_to<GiNaC::numeric>(p.diff(u, static_cast<unsigned>(j)).subs(u == c).evalf()));
}

/** The interior basis of a Galerkin interval of a model of order g: bubble j is
 *  u^g (1 - u)^g P_j^(g,g)(2u - 1) (Jacobi), scaled to at most 1 on [0, 1]. Each vanishes with its
 *  first g - 1 derivatives at both ends, and their g-th derivatives are Legendre polynomials
 *  (Rodrigues' formula), orthogonal on [0, 1]: the part of d2S/dz2 that x^(g)^2 gives is
 *  diagonal, and the Hermite interpolant, orthogonal to every bubble in that part, is the
 *  polynomial at z = 0. */
std::vector<ex> bubbles(int g, int m, const GiNaC::symbol& u) {
  std::vector<ex> out;
  for (int j = 0; j < m; ++j) {
    // P_j^(g,g)(2u - 1) = sum_s binom(j + g, j - s) binom(j + g, s) (u - 1)^s u^(j - s); its
    // largest magnitude on [0, 1] is binom(j + g, j), that of u^g (1 - u)^g is 4^-g.
    ex jacobi = 0;
    for (int k = 0; k <= j; ++k)
      jacobi += GiNaC::binomial(GiNaC::numeric(j + g), GiNaC::numeric(j - k)) *
                GiNaC::binomial(GiNaC::numeric(j + g), GiNaC::numeric(k)) * GiNaC::pow(u - 1, k) * GiNaC::pow(u, j - k);
    const ex scale = GiNaC::pow(GiNaC::numeric(4), g) / GiNaC::binomial(GiNaC::numeric(j + g), GiNaC::numeric(j));
    out.push_back((scale * GiNaC::pow(u, g) * GiNaC::pow(1 - u, g) * jacobi).expand());
  }
  return out;
}

}  // namespace

GalerkinInterval galerkin_interval(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s) {
  using GiNaC::numeric;
  const long saved = GiNaC::Digits;
  GiNaC::Digits = std::max<long>(saved, 60);
  const std::size_t n = model.coords.size();
  const int g = model.order, m = spec.interior_points;
  GalerkinInterval out;
  // The polynomial of degree s + g - 1 on the interval: the Hermite interpolant of the nodes' jets
  // (degree 2g - 1) plus the interior coefficients z times the bubbles (degree 2g + m - 1).
  const GiNaC::symbol u("u");
  const HermiteBasis hb = hermite_basis(g, u);
  const std::vector<ex> bubble = bubbles(g, m, u);
  for (int j = 0; j < m; ++j) {
    for (std::size_t i = 0; i < n; ++i) out.z.emplace_back("z_" + std::to_string(j) + "_" + std::to_string(i));
  }
  const ex h = s.h;
  Quadrature quad = spec.family->quadrature(spec.stages);
  ex total = 0;
  for (std::size_t stage = 0; stage < quad.nodes.size(); ++stage) {
    const numeric c = GiNaC::ex_to<numeric>(quad.nodes[stage].evalf());
    std::vector<std::vector<ex>> values(static_cast<std::size_t>(g) + 1, std::vector<ex>(n, 0));
    for (int j = 0; j <= g; ++j) {
      for (int k = 0; k < g; ++k) {
        const numeric ca = derivative_at(hb.at[static_cast<std::size_t>(k)], u, j, c);
        const numeric cb = derivative_at(hb.bt[static_cast<std::size_t>(k)], u, j, c);
        const ex scale = GiNaC::pow(h, k - j);
        for (std::size_t i = 0; i < n; ++i) {
          values[static_cast<std::size_t>(j)][i] +=
              scale * (ca * s.q0[static_cast<std::size_t>(k) * n + i] + cb * s.q1[static_cast<std::size_t>(k) * n + i]);
        }
      }
      for (int jj = 0; jj < m; ++jj) {
        const numeric cz = derivative_at(bubble[static_cast<std::size_t>(jj)], u, j, c);
        for (std::size_t i = 0; i < n; ++i)
          values[static_cast<std::size_t>(j)][i] += GiNaC::pow(h, -j) * cz * out.z[static_cast<std::size_t>(jj) * n + i];
      }
    }
    const ex weight = cleaned(GiNaC::ex_to<numeric>(quad.weights[stage].evalf()));
    total += weight * evaluate_at(model, model.lagrangian, s.t0 + c * (s.t1 - s.t0), values);
  }
  out.action = h * total;
  // Starting values: z = 0, the Hermite interpolant of the nodes' jets.
  out.start.assign(out.z.size(), ex(0));
  GiNaC::Digits = saved;
  return out;
}

KernelSymbols::KernelSymbols(const LagModel& model) {
  for (int i = 0; i < model.dim(); ++i) {
    q0.emplace_back("q0_" + std::to_string(i));
    q1.emplace_back("q1_" + std::to_string(i));
  }
  for (const ParamDecl& param : model.params) p.push_back(param.symbol);
}

ex trapezoid_lagrangian(const LagModel& model, const DiscretizationSpec&, const KernelSymbols& s, Gauss2Positions) {
  const std::size_t n = model.coords.size();
  const ex h = s.h;
  std::vector<ex> x0 = block(s.q0, 0, n), x1 = block(s.q1, 0, n), v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = (x1[i] - x0[i]) / h;
  return h / 2 * (evaluate_at(model, model.lagrangian, s.t0, {x0, v}) + evaluate_at(model, model.lagrangian, s.t1, {x1, v}));
}

ex midpoint_lagrangian(const LagModel& model, const DiscretizationSpec&, const KernelSymbols& s, Gauss2Positions) {
  const std::size_t n = model.coords.size();
  const ex h = s.h;
  std::vector<ex> x0 = block(s.q0, 0, n), x1 = block(s.q1, 0, n), v(n), xm(n);
  for (std::size_t i = 0; i < n; ++i) {
    v[i] = (x1[i] - x0[i]) / h;
    xm[i] = (x0[i] + x1[i]) / 2;
  }
  return h * evaluate_at(model, model.lagrangian, (s.t0 + s.t1) / 2, {xm, v});
}

ex trapezoid_alpha_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                              Gauss2Positions) {
  const std::size_t n = model.coords.size();
  const ex h = s.h;
  const ex a = spec.alpha;
  std::vector<ex> x0 = block(s.q0, 0, n), v0 = block(s.q0, 1, n);
  std::vector<ex> x1 = block(s.q1, 0, n), v1 = block(s.q1, 1, n), a0(n), a1(n);
  for (std::size_t i = 0; i < n; ++i) {
    a0[i] = (((1 - 3 * a) * v1[i] - (1 + 3 * a) * v0[i]) * h + 6 * a * (x1[i] - x0[i])) / (h * h);
    a1[i] = (((1 + 3 * a) * v1[i] - (1 - 3 * a) * v0[i]) * h - 6 * a * (x1[i] - x0[i])) / (h * h);
  }
  return h / 2 * (evaluate_at(model, model.lagrangian, s.t0, {x0, v0, a0}) +
                  evaluate_at(model, model.lagrangian, s.t1, {x1, v1, a1}));
}

ex gauss2_lagrangian(const LagModel& model, const DiscretizationSpec&, const KernelSymbols& s, Gauss2Positions positions) {
  const std::size_t n = model.coords.size();
  const ex h = s.h, t0 = s.t0, t1 = s.t1;
  std::vector<ex> x0 = block(s.q0, 0, n), v0 = block(s.q0, 1, n);
  std::vector<ex> x1 = block(s.q1, 0, n), v1 = block(s.q1, 1, n);
  const ex r3 = GiNaC::sqrt(ex(3));
  ex total = 0;
  for (int stage = 0; stage < 2; ++stage) {
    const ex c = stage == 0 ? ex(GiNaC::numeric(1, 2)) - r3 / 6 : ex(GiNaC::numeric(1, 2)) + r3 / 6;
    // Cubic Hermite basis on [0, 1] and its first two derivatives at c.
    const ex h00 = (2 * c * c * c - 3 * c * c + 1).expand(), h10 = (c * c * c - 2 * c * c + c).expand();
    const ex h01 = (-2 * c * c * c + 3 * c * c).expand(), h11 = (c * c * c - c * c).expand();
    const ex d00 = (6 * c * c - 6 * c).expand(), d10 = (3 * c * c - 4 * c + 1).expand();
    const ex d01 = (-6 * c * c + 6 * c).expand(), d11 = (3 * c * c - 2 * c).expand();
    const ex e00 = (12 * c - 6).expand(), e10 = (6 * c - 4).expand();
    const ex e01 = (-12 * c + 6).expand(), e11 = (6 * c - 2).expand();
    std::vector<ex> Q(n), V(n), A(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (positions == Gauss2Positions::hermite) {
        Q[i] = h00 * x0[i] + h10 * h * v0[i] + h01 * x1[i] + h11 * h * v1[i];
      } else {
        Q[i] = (1 - c) * x0[i] + c * x1[i] - h / 12 * (v1[i] - v0[i]);
      }
      V[i] = (d00 * x0[i] + d01 * x1[i]) / h + d10 * v0[i] + d11 * v1[i];
      A[i] = (e00 * x0[i] + e01 * x1[i]) / (h * h) + (e10 * v0[i] + e11 * v1[i]) / h;
    }
    total += evaluate_at(model, model.lagrangian, t0 + c * (t1 - t0), {Q, V, A});
  }
  return h / 2 * total;
}

ex hermite_gauss_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                            Gauss2Positions) {
  // The interpolant x(t0 + u h) = sum_k h^k (at[k](u) x0^(k) + bt[k](u) x1^(k)); its j-th time
  // derivative at a stage c is sum_k h^(k-j) (at[k]^(j)(c) x0^(k) + bt[k]^(j)(c) x1^(k)).
  const std::size_t n = model.coords.size();
  const ex h = s.h, t0 = s.t0, t1 = s.t1;
  const int g = model.order;
  const GiNaC::symbol u("u");
  const HermiteBasis basis = hermite_basis(g, u);
  const Quadrature quad = gauss_legendre(spec.stages);
  ex total = 0;
  for (std::size_t stage = 0; stage < quad.nodes.size(); ++stage) {
    const ex c = quad.nodes[stage];
    std::vector<std::vector<ex>> values(static_cast<std::size_t>(g) + 1, std::vector<ex>(n, 0));
    for (int k = 0; k < g; ++k) {
      const std::vector<ex> x0 = block(s.q0, static_cast<std::size_t>(k), n);
      const std::vector<ex> x1 = block(s.q1, static_cast<std::size_t>(k), n);
      ex da = basis.at[static_cast<std::size_t>(k)], db = basis.bt[static_cast<std::size_t>(k)];
      for (int j = 0; j <= g; ++j) {
        const ex ca = da.subs(u == c).expand(), cb = db.subs(u == c).expand();
        const ex scale = GiNaC::pow(h, k - j);
        for (std::size_t i = 0; i < n; ++i) values[static_cast<std::size_t>(j)][i] += scale * (ca * x0[i] + cb * x1[i]);
        da = da.diff(u);
        db = db.diff(u);
      }
    }
    total += quad.weights[stage] * evaluate_at(model, model.lagrangian, t0 + c * (t1 - t0), values);
  }
  return h * total;
}

ex galerkin_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s, Gauss2Positions) {
  if (spec.interior_points > 0) throw std::logic_error(spec.name + " has interior values: it has no closed form");
  return galerkin_interval(model, spec, s).action;
}

ex discrete_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                       Gauss2Positions positions) {
  if (spec.family == nullptr || spec.family->build == nullptr) throw std::logic_error(spec.name + " has no builder");
  return spec.family->build(model, spec, s, positions);
}

ex interval_clock(const LagModel& model, const KernelSymbols& s) {
  const std::size_t n = model.coords.size();
  std::vector<std::vector<ex>> values;
  if (model.order == 1) {
    std::vector<ex> x0 = block(s.q0, 0, n), v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = (s.q1[i] - s.q0[i]) / s.h;
    values = {x0, v};
  } else {
    for (int k = 0; k < model.order; ++k) values.push_back(block(s.q0, static_cast<std::size_t>(k), n));
  }
  return s.h * evaluate_at(model, model.clock, s.t0, values);
}

}  // namespace pardel_codegen

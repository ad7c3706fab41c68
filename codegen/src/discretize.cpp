/**
 * @file discretize.cpp
 * The discrete Lagrangians: substitution of interpolated stage values into the continuous L
 * and quadrature. Order 1: trapezoid and midpoint; order 2: the seed's trapezoid(alpha) family
 * and 2-stage Gauss on the cubic Hermite interpolant of (q0, v0, q1, v1).
 */
#include "pardel_codegen/discretize.hpp"

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

}  // namespace

KernelSymbols::KernelSymbols(const LagModel& model) {
  for (int i = 0; i < model.dim(); ++i) {
    q0.emplace_back("q0_" + std::to_string(i));
    q1.emplace_back("q1_" + std::to_string(i));
  }
  for (const ParamDecl& param : model.params) p.push_back(param.symbol);
}

ex discrete_lagrangian(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                       Gauss2Positions positions) {
  const std::size_t n = model.coords.size();
  const ex h = s.h, t0 = s.t0, t1 = s.t1;
  const ex& L = model.lagrangian;
  switch (spec.kind) {
    case DiscretizationKind::trapezoid:
    case DiscretizationKind::midpoint: {
      std::vector<ex> x0 = block(s.q0, 0, n), x1 = block(s.q1, 0, n), v(n), xm(n);
      for (std::size_t i = 0; i < n; ++i) {
        v[i] = (x1[i] - x0[i]) / h;
        xm[i] = (x0[i] + x1[i]) / 2;
      }
      if (spec.kind == DiscretizationKind::trapezoid) {
        return h / 2 * (evaluate_at(model, L, t0, {x0, v}) + evaluate_at(model, L, t1, {x1, v}));
      }
      return h * evaluate_at(model, L, (t0 + t1) / 2, {xm, v});
    }
    case DiscretizationKind::trapezoid_alpha: {
      const ex a = spec.alpha;
      std::vector<ex> x0 = block(s.q0, 0, n), v0 = block(s.q0, 1, n);
      std::vector<ex> x1 = block(s.q1, 0, n), v1 = block(s.q1, 1, n), a0(n), a1(n);
      for (std::size_t i = 0; i < n; ++i) {
        a0[i] = (((1 - 3 * a) * v1[i] - (1 + 3 * a) * v0[i]) * h + 6 * a * (x1[i] - x0[i])) / (h * h);
        a1[i] = (((1 + 3 * a) * v1[i] - (1 - 3 * a) * v0[i]) * h - 6 * a * (x1[i] - x0[i])) / (h * h);
      }
      return h / 2 * (evaluate_at(model, L, t0, {x0, v0, a0}) + evaluate_at(model, L, t1, {x1, v1, a1}));
    }
    case DiscretizationKind::gauss2: {
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
        total += evaluate_at(model, L, t0 + c * (t1 - t0), {Q, V, A});
      }
      return h / 2 * total;
    }
  }
  return 0;
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

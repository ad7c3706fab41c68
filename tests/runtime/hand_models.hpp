/**
 * @file hand_models.hpp
 * Hand-written kernels (independent of the code generator) for the runtime tests:
 *  - harmonic oscillator L = (x'^2 - omega^2 x^2)/2, trapezoid and midpoint;
 *  - Bratu L = u'^2/2 - lambda exp(u), trapezoid (u'' + lambda e^u = 0);
 *  - forced particle L = x'^2/2 + t x (time-dependent) with clock h (1 + c x^2);
 *  - cubic spline L = |q''|^2/2 (order 2) with the trapezoid(alpha) family of the seed.
 * Each model is a pardel_model as pardel-gen would emit it; hand::problem() poses a boundary-value
 * problem with one of them.
 */
#ifndef PARDEL_TESTS_RUNTIME_HAND_MODELS_HPP
#define PARDEL_TESTS_RUNTIME_HAND_MODELS_HPP

#include <cmath>

#include "pardel/kernel_abi.h"
#include "pardel/pardel.hpp"

namespace hand {

// ---- harmonic oscillator, trapezoid: Ld = (x1-x0)^2/(2h) - h w^2 (x0^2 + x1^2)/4
inline void harmonic_trap_full(double h, double, double, const double* q0, const double* q1, const double* p,
                               double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {
  const double w2 = p[0] * p[0], dx = q1[0] - q0[0];
  *Ld = dx * dx / (2 * h) - h * w2 * (q0[0] * q0[0] + q1[0] * q1[0]) / 4;
  D1[0] = -dx / h - h * w2 * q0[0] / 2;
  D2[0] = dx / h - h * w2 * q1[0] / 2;
  D11[0] = 1 / h - h * w2 / 2;
  D12[0] = -1 / h;
  D22[0] = 1 / h - h * w2 / 2;
}
inline void harmonic_trap_sweep(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                                double* D1, double* D2, double* D11, double* D22) {
  double Ld, D12;
  harmonic_trap_full(h, t0, t1, q0, q1, p, &Ld, D1, D2, D11, &D12, D22);
}
inline void harmonic_trap_grad(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                               double* Ld, double* D1, double* D2) {
  double a, b, c;
  harmonic_trap_full(h, t0, t1, q0, q1, p, Ld, D1, D2, &a, &b, &c);
}
inline double harmonic_trap_action(double h, double t0, double t1, const double* q0, const double* q1,
                                   const double* p) {
  double Ld, D1, D2;
  harmonic_trap_grad(h, t0, t1, q0, q1, p, &Ld, &D1, &D2);
  return Ld;
}

// ---- harmonic oscillator, midpoint: Ld = (x1-x0)^2/(2h) - h w^2 ((x0+x1)/2)^2 / 2
inline void harmonic_mid_full(double h, double, double, const double* q0, const double* q1, const double* p,
                              double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {
  const double w2 = p[0] * p[0], dx = q1[0] - q0[0], m = (q0[0] + q1[0]) / 2;
  *Ld = dx * dx / (2 * h) - h * w2 * m * m / 2;
  D1[0] = -dx / h - h * w2 * m / 2;
  D2[0] = dx / h - h * w2 * m / 2;
  D11[0] = 1 / h - h * w2 / 4;
  D12[0] = -1 / h - h * w2 / 4;
  D22[0] = 1 / h - h * w2 / 4;
}
inline void harmonic_mid_sweep(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                               double* D1, double* D2, double* D11, double* D22) {
  double Ld, D12;
  harmonic_mid_full(h, t0, t1, q0, q1, p, &Ld, D1, D2, D11, &D12, D22);
}
inline void harmonic_mid_grad(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                              double* Ld, double* D1, double* D2) {
  double a, b, c;
  harmonic_mid_full(h, t0, t1, q0, q1, p, Ld, D1, D2, &a, &b, &c);
}
inline double harmonic_mid_action(double h, double t0, double t1, const double* q0, const double* q1,
                                  const double* p) {
  double Ld, D1, D2;
  harmonic_mid_grad(h, t0, t1, q0, q1, p, &Ld, &D1, &D2);
  return Ld;
}

inline const char* const harmonic_coords[] = {"x"};
inline const char* const harmonic_params[] = {"omega"};
inline const double harmonic_defaults[] = {1.0};
inline const pardel_discretization harmonic_discs[] = {
    {"trapezoid", 2, harmonic_trap_full, harmonic_trap_sweep, harmonic_trap_grad, harmonic_trap_action},
    {"midpoint", 2, harmonic_mid_full, harmonic_mid_sweep, harmonic_mid_grad, harmonic_mid_action},
};
inline const pardel_model harmonic = {PARDEL_KERNEL_ABI_VERSION, "hand_harmonic", "tests/runtime/hand_models.hpp",
                                      1, 1, 1, harmonic_coords, 1, harmonic_params, harmonic_defaults, 0, nullptr,
                                      2, harmonic_discs, nullptr, PARDEL_COST_ACTION};

// ---- Bratu, trapezoid: Ld = (u1-u0)^2/(2h) - h lambda (e^u0 + e^u1)/2
inline void bratu_full(double h, double, double, const double* q0, const double* q1, const double* p, double* Ld,
                       double* D1, double* D2, double* D11, double* D12, double* D22) {
  const double l = p[0], du = q1[0] - q0[0], e0 = std::exp(q0[0]), e1 = std::exp(q1[0]);
  *Ld = du * du / (2 * h) - h * l * (e0 + e1) / 2;
  D1[0] = -du / h - h * l * e0 / 2;
  D2[0] = du / h - h * l * e1 / 2;
  D11[0] = 1 / h - h * l * e0 / 2;
  D12[0] = -1 / h;
  D22[0] = 1 / h - h * l * e1 / 2;
}
inline void bratu_sweep(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                        double* D1, double* D2, double* D11, double* D22) {
  double Ld, D12;
  bratu_full(h, t0, t1, q0, q1, p, &Ld, D1, D2, D11, &D12, D22);
}
inline void bratu_grad(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                       double* Ld, double* D1, double* D2) {
  double a, b, c;
  bratu_full(h, t0, t1, q0, q1, p, Ld, D1, D2, &a, &b, &c);
}
inline double bratu_action(double h, double t0, double t1, const double* q0, const double* q1, const double* p) {
  double Ld, D1, D2;
  bratu_grad(h, t0, t1, q0, q1, p, &Ld, &D1, &D2);
  return Ld;
}
inline const char* const bratu_coords[] = {"u"};
inline const char* const bratu_params[] = {"lambda"};
inline const double bratu_defaults[] = {1.0};
inline const pardel_discretization bratu_discs[] = {
    {"trapezoid", 2, bratu_full, bratu_sweep, bratu_grad, bratu_action}};
inline const pardel_model bratu = {PARDEL_KERNEL_ABI_VERSION, "hand_bratu", "tests/runtime/hand_models.hpp",
                                   1, 1, 1, bratu_coords, 1, bratu_params, bratu_defaults, 0, nullptr, 1,
                                   bratu_discs, nullptr, PARDEL_COST_ACTION};

// ---- forced particle (time-dependent): Ld = (x1-x0)^2/(2 dt) + dt (t0 x0 + t1 x1)/2, dt = t1 - t0;
// the kinetic term uses the node times so that the same kernel serves every clock mode.
inline void forced_full(double, double t0, double t1, const double* q0, const double* q1, const double*, double* Ld,
                        double* D1, double* D2, double* D11, double* D12, double* D22) {
  const double dt = t1 - t0, dx = q1[0] - q0[0];
  *Ld = dx * dx / (2 * dt) + dt * (t0 * q0[0] + t1 * q1[0]) / 2;
  D1[0] = -dx / dt + dt * t0 / 2;
  D2[0] = dx / dt + dt * t1 / 2;
  D11[0] = 1 / dt;
  D12[0] = -1 / dt;
  D22[0] = 1 / dt;
}
inline void forced_sweep(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                         double* D1, double* D2, double* D11, double* D22) {
  double Ld, D12;
  forced_full(h, t0, t1, q0, q1, p, &Ld, D1, D2, D11, &D12, D22);
}
inline void forced_grad(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                        double* Ld, double* D1, double* D2) {
  double a, b, c;
  forced_full(h, t0, t1, q0, q1, p, Ld, D1, D2, &a, &b, &c);
}
inline double forced_action(double h, double t0, double t1, const double* q0, const double* q1, const double* p) {
  double Ld, D1, D2;
  forced_grad(h, t0, t1, q0, q1, p, &Ld, &D1, &D2);
  return Ld;
}
/** Clock h (1 + c x0^2): time runs faster where |x| is large. */
inline double forced_clock(double h, double, const double* q0, const double*, const double* p) {
  return h * (1 + p[0] * q0[0] * q0[0]);
}
inline const char* const forced_coords[] = {"x"};
inline const char* const forced_params[] = {"c"};
inline const double forced_defaults[] = {0.5};
inline const pardel_discretization forced_discs[] = {
    {"trapezoid", 2, forced_full, forced_sweep, forced_grad, forced_action}};
inline const pardel_model forced = {PARDEL_KERNEL_ABI_VERSION, "hand_forced", "tests/runtime/hand_models.hpp",
                                    1, 1, 1, forced_coords, 1, forced_params, forced_defaults, 1, forced_clock, 1,
                                    forced_discs, nullptr, PARDEL_COST_ACTION};

// ---- cubic spline in one coordinate, L = q''^2/2, trapezoid(alpha): Ld = h/2 (a0^2 + a1^2)/2 with
// a0 = g0.z, a1 = g1.z, z = (q0, v0, q1, v1) (seed Example exp:trapezoidal). alpha = p[0].
inline void spline_vectors(double h, double a, double g0[4], double g1[4]) {
  const double h2 = h * h;
  g0[0] = -6 * a / h2; g0[1] = -(1 + 3 * a) / h; g0[2] = 6 * a / h2; g0[3] = (1 - 3 * a) / h;
  g1[0] = 6 * a / h2;  g1[1] = -(1 - 3 * a) / h; g1[2] = -6 * a / h2; g1[3] = (1 + 3 * a) / h;
}
inline void spline_full(double h, double, double, const double* q0, const double* q1, const double* p, double* Ld,
                        double* D1, double* D2, double* D11, double* D12, double* D22) {
  double g0[4], g1[4];
  spline_vectors(h, p[0], g0, g1);
  const double z[4] = {q0[0], q0[1], q1[0], q1[1]};
  double a0 = 0, a1 = 0;
  for (int i = 0; i < 4; ++i) {
    a0 += g0[i] * z[i];
    a1 += g1[i] * z[i];
  }
  *Ld = h / 4 * (a0 * a0 + a1 * a1);
  double grad[4], H[4][4];
  for (int i = 0; i < 4; ++i) {
    grad[i] = h / 2 * (a0 * g0[i] + a1 * g1[i]);
    for (int j = 0; j < 4; ++j) H[i][j] = h / 2 * (g0[i] * g0[j] + g1[i] * g1[j]);
  }
  D1[0] = grad[0]; D1[1] = grad[1]; D2[0] = grad[2]; D2[1] = grad[3];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      D11[i * 2 + j] = H[i][j];
      D12[i * 2 + j] = H[i][2 + j];
      D22[i * 2 + j] = H[2 + i][2 + j];
    }
}
inline void spline_sweep(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                         double* D1, double* D2, double* D11, double* D22) {
  double Ld, D12[4];
  spline_full(h, t0, t1, q0, q1, p, &Ld, D1, D2, D11, D12, D22);
}
inline void spline_grad(double h, double t0, double t1, const double* q0, const double* q1, const double* p,
                        double* Ld, double* D1, double* D2) {
  double a[4], b[4], c[4];
  spline_full(h, t0, t1, q0, q1, p, Ld, D1, D2, a, b, c);
}
inline double spline_action(double h, double t0, double t1, const double* q0, const double* q1, const double* p) {
  double Ld, D1[2], D2[2];
  spline_grad(h, t0, t1, q0, q1, p, &Ld, D1, D2);
  return Ld;
}
inline const char* const spline_coords[] = {"x"};
inline const char* const spline_params[] = {"alpha"};
inline const double spline_defaults[] = {1.0};
inline const pardel_discretization spline_discs[] = {
    {"trapezoid(alpha)", 2, spline_full, spline_sweep, spline_grad, spline_action}};
inline const pardel_model spline = {PARDEL_KERNEL_ABI_VERSION, "hand_spline", "tests/runtime/hand_models.hpp",
                                    2, 1, 2, spline_coords, 1, spline_params, spline_defaults, 0, nullptr, 1,
                                    spline_discs, nullptr, PARDEL_COST_ACTION};

/** A problem with a one-coordinate model of this file (its first discretization): one parameter,
 *  t in [0, T] on N intervals, from a to b. */
inline pardel::Problem problem(const pardel_model& m, double param, double T, int N, double a, double b) {
  pardel::Problem p;
  p.model = &m;
  p.discretization = &m.discretizations[0];
  p.params = {param};
  p.T = T;
  p.N = N;
  p.q0 = {a};
  p.qN = {b};
  return p;
}

}  // namespace hand

#endif  // PARDEL_TESTS_RUNTIME_HAND_MODELS_HPP

#!/usr/bin/python3
"""Checks the mathematics of the bundled models (lagrangians/*.lag) against their defining
properties, with quantities derived independently here:
  - zermelo, zermelo_tv: the Randers metric F is 1 exactly when |v - W| = 1 (unit thrust
    relative to the wind), and positively 1-homogeneous; the clock is F;
  - fuel_nav, interp_fuel: L vanishes along the drift flow q' = W(q) (for interp_fuel with
    q'' = DW q', DW obtained here by sympy.diff of W, not from the file's hand-written Jacobian);
  - spacecraft: with accelerations from the textbook rotating-frame equations
    x'' - 2y' = Omega_x + u_x, y'' + 2x' = Omega_y + u_y (Omega written and differentiated here),
    the model's L equals |u|^2, so 0 on ballistic arcs (the seed's printed y sign would fail);
  - the test models: their Euler-Lagrange equations are the documented ones."""

import os
import random
import sys
import unittest

import mpmath
import sympy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools", "codegen_peer"))
import sympy_kernels as sk  # noqa: E402


def load(name):
    return sk.parse_lag(os.path.join(ROOT, "lagrangians", name + ".lag"))


def let(model, name):
    """A let's definition with every let expanded, in the model's own symbols."""
    for sym, expr in model.lets:
        if sym.name == name:
            return model.expand(expr)
    raise KeyError(name)


def params(model, **overrides):
    return {sym: sympy.Float(overrides.get(name, v), 30) for (name, v), sym in zip(model.params, model.param_symbols)}


def evaluate(model, expr, t, jets, param_values):
    """expr at time t with jets[i][k] the k-th derivative of coordinate i, in 30 digits."""
    repl = dict(param_values)
    repl[model.time] = t
    for symbols, values in zip(model.jets, jets):
        repl.update(zip(symbols, values))
    return sympy.N(model.expand(expr).xreplace(repl), 30)


class Zermelo(unittest.TestCase):
    def check_unit_thrust(self, name, time_dependent):
        model = load(name)
        p = params(model)
        rng = random.Random(7)
        x, y = model.jets[0][0], model.jets[1][0]
        w1, w2 = let(model, "W1"), let(model, "W2")
        for _ in range(10):
            q = [sympy.Float(rng.uniform(0, 6), 30), sympy.Float(rng.uniform(0, 6), 30)]
            t = sympy.Float(rng.uniform(0, 10), 30) if time_dependent else sympy.Integer(0)
            at = {x: q[0], y: q[1], model.time: t, **p}
            W = [sympy.N(w1.xreplace(at), 30), sympy.N(w2.xreplace(at), 30)]
            if W[0] ** 2 + W[1] ** 2 >= 0.98:
                continue
            angle = sympy.Float(rng.uniform(0, 6.28), 30)
            v = [W[0] + sympy.cos(angle), W[1] + sympy.sin(angle)]   # |v - W| = 1
            lam = sympy.Float(rng.uniform(0.2, 3), 30)
            F = evaluate(model, let(model, "F"), t, [[q[0], lam * v[0]], [q[1], lam * v[1]]], p)
            self.assertLess(abs(F - lam), 1e-25)                         # F(q, lam v) = lam
            L = evaluate(model, model.lagrangian, t, [[q[0], v[0]], [q[1], v[1]]], p)
            self.assertLess(abs(L - 1), 1e-25)
            clock = evaluate(model, model.clock, t, [[q[0], lam * v[0]], [q[1], lam * v[1]]], p)
            self.assertLess(abs(clock - lam), 1e-25)                     # dt/ds = F

    def test_zermelo_randers_metric_measures_time_at_unit_thrust(self):
        self.check_unit_thrust("zermelo", time_dependent=False)

    def test_zermelo_tv_randers_metric_measures_time_at_unit_thrust(self):
        self.check_unit_thrust("zermelo_tv", time_dependent=True)

    def test_zermelo_wind_is_the_seeds_four_vortices(self):
        model = load("zermelo")
        x, y = model.jets[0][0], model.jets[1][0]

        def R(a, b):
            d = 3 * ((x - a) ** 2 + (y - b) ** 2) + 1
            return (-(y - b) / d, (x - a) / d)
        parts = [R(2, 2), R(4, 4), R(2, 5), R(5, 1)]
        signs = [-1, -1, -1, 1]
        s = model.param_symbols[0]
        for i, name in enumerate(("W1", "W2")):
            seed = s * sum(sign * part[i] for sign, part in zip(signs, parts))
            self.assertEqual(sympy.simplify(let(model, name) - seed), 0)


class FuelNavigation(unittest.TestCase):
    def test_fuel_nav_lagrangian_vanishes_along_the_drift(self):
        model = load("fuel_nav")
        x, y = model.jets[0][0], model.jets[1][0]
        rng = random.Random(3)
        for _ in range(5):
            q = [sympy.Float(rng.uniform(0, 6), 30), sympy.Float(rng.uniform(0, 6), 30)]
            W = [sympy.cos(2 * q[0] - q[1] - 6), sympy.Rational(2, 3) * sympy.sin(q[1]) + q[0] - 3]
            L = evaluate(model, model.lagrangian, 0, [[q[0], W[0]], [q[1], W[1]]], {})
            self.assertLess(abs(L), 1e-28)

    def test_interp_fuel_lagrangian_vanishes_along_the_drift_and_weights_control_changes(self):
        model = load("interp_fuel")
        x, y = model.jets[0][0], model.jets[1][0]
        W = [sympy.cos(2 * x - y - 6), sympy.Rational(2, 3) * sympy.sin(y) + x - 3]
        DW = [[sympy.diff(w, v) for v in (x, y)] for w in W]
        p = params(model)
        rng = random.Random(5)
        for _ in range(5):
            q = {x: sympy.Float(rng.uniform(0, 6), 30), y: sympy.Float(rng.uniform(0, 6), 30)}
            v = [w.xreplace(q) for w in W]
            a = [sum(DW[i][j].xreplace(q) * v[j] for j in range(2)) for i in range(2)]
            L = evaluate(model, model.lagrangian, 0, [[q[x], v[0], a[0]], [q[y], v[1], a[1]]], p)
            self.assertLess(abs(L), 1e-27)
            # A change du of the control's derivative costs c |du|^2 / 2.
            du = [sympy.Float(rng.uniform(-1, 1), 30) for _ in range(2)]
            L = evaluate(model, model.lagrangian, 0,
                         [[q[x], v[0], a[0] + du[0]], [q[y], v[1], a[1] + du[1]]], p)
            self.assertLess(abs(L - 50 * (du[0] ** 2 + du[1] ** 2) / 2), 1e-25)


class Spacecraft(unittest.TestCase):
    def test_lagrangian_is_the_squared_control_of_the_textbook_equations(self):
        model = load("spacecraft")
        p = params(model)
        names = [n for n, _ in model.params]
        val = {n: p[s] for n, s in zip(names, model.param_symbols)}
        X, Y, T = sympy.symbols("X Y T", real=True)
        xm = val["r_M"] * sympy.cos(val["w_M"] * T + val["th_M0"])
        ym = val["r_M"] * sympy.sin(val["w_M"] * T + val["th_M0"])
        dS = sympy.sqrt((X + 1) ** 2 + Y ** 2)
        dE = sympy.sqrt(X ** 2 + Y ** 2)
        dM = sympy.sqrt((X - xm) ** 2 + (Y - ym) ** 2)
        omega = ((X + 1) ** 2 + Y ** 2) / 2 + val["m_S"] / dS + val["m_E"] / dE + val["m_M"] / dM
        rng = random.Random(11)
        for _ in range(6):
            state = {X: sympy.Float(rng.uniform(-0.004, 0.004), 30), Y: sympy.Float(rng.uniform(-0.004, 0.004), 30),
                     T: sympy.Float(rng.uniform(0, 0.3), 30)}
            vel = [sympy.Float(rng.uniform(-0.1, 0.1), 30) for _ in range(2)]
            u = [sympy.Float(rng.uniform(-2, 2), 30) for _ in range(2)]
            ox, oy = (sympy.N(sympy.diff(omega, v).xreplace(state), 30) for v in (X, Y))
            acc = [2 * vel[1] + ox + u[0], -2 * vel[0] + oy + u[1]]      # textbook signs
            jets = [[state[X], vel[0], acc[0]], [state[Y], vel[1], acc[1]]]
            L = evaluate(model, model.lagrangian, state[T], jets, p)
            expected = u[0] ** 2 + u[1] ** 2
            self.assertLess(abs(L - expected), 1e-20 * max(1, abs(expected)))
            # The clock: half the harmonic mean of the distances to the Earth and the Moon, over r_M.
            de, dm = sympy.N(dE.xreplace(state), 30), sympy.N(dM.xreplace(state), 30)
            clock = evaluate(model, model.clock, state[T], jets, p)
            self.assertLess(abs(clock - de * dm / ((de + dm) * val["r_M"])), 1e-25)

    def test_constants_follow_their_sources(self):
        model = load("spacecraft")
        v = {n: float(x) for n, x in model.params}
        total = 132712440041.279419 + 398600.435507 + 4902.800118
        self.assertAlmostEqual(v["m_S"] + v["m_E"] + v["m_M"], 1.0, places=15)
        self.assertAlmostEqual(v["m_E"], 398600.435507 / total, places=18)
        self.assertAlmostEqual(v["r_M"], 384400 / 149597870.7, places=15)
        self.assertAlmostEqual(v["w_M"], 365.25636 / 29.530589, places=12)


class TestModels(unittest.TestCase):
    """Euler-Lagrange equations of the small models, derived here with SymPy."""

    def euler_lagrange(self, model):
        t = sympy.Symbol("t")
        fs = [sympy.Function(c)(t) for c in model.coords]
        repl = {}
        for f, jet in zip(fs, model.jets):
            for k, sym in enumerate(jet):
                repl[sym] = f.diff(t, k)
        L = model.expand(model.lagrangian).xreplace(repl).xreplace({model.time: t})
        eqs = []
        for f in fs:
            e = 0
            for k in range(model.order + 1):
                e += (-1) ** k * sympy.diff(sympy.diff(L, f.diff(t, k)), t, k)
            eqs.append(sympy.simplify(e))
        return t, fs, eqs

    def test_bratu(self):
        model = load("bratu")
        t, (u,), (e,) = self.euler_lagrange(model)
        lam = model.param_symbols[0]
        self.assertEqual(sympy.simplify(e + (u.diff(t, 2) + lam * sympy.exp(u))), 0)

    def test_pendulum(self):
        model = load("pendulum")
        t, (x,), (e,) = self.euler_lagrange(model)
        g, l = model.param_symbols
        self.assertEqual(sympy.simplify(e + (x.diff(t, 2) + g / l * sympy.sin(x))), 0)

    def test_harmonic(self):
        model = load("harmonic")
        t, (x,), (e,) = self.euler_lagrange(model)
        w = model.param_symbols[0]
        self.assertEqual(sympy.simplify(e + (x.diff(t, 2) + w ** 2 * x)), 0)

    def test_spline_is_fourth_derivative(self):
        t, fs, eqs = self.euler_lagrange(load("spline"))
        for f, e in zip(fs, eqs):
            self.assertEqual(sympy.simplify(e - f.diff(t, 4)), 0)

    def test_sphere_geodesic_great_circle(self):
        model = load("sphere_geodesic")
        t, (th, ph), eqs = self.euler_lagrange(model)
        # The equator at unit speed, and a meridian, are solutions.
        for sol in ({th: sympy.pi / 2 + 0 * t, ph: t}, {th: t, ph: 0 * t}):
            for e in eqs:
                self.assertEqual(sympy.simplify(e.subs(sol).doit()), 0)


if __name__ == "__main__":
    unittest.main()

#!/usr/bin/python3
"""Checks the SymPy reference (tools/codegen_peer/sympy_kernels.py) on its own: exact discrete
actions of known solutions, agreement of its two differentiation paths, high-precision finite
differences, and file:line:col errors for bad .lag input."""

import os
import sys
import tempfile
import unittest

import mpmath
import sympy

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools", "codegen_peer"))
import sympy_kernels as sk  # noqa: E402


def bundled(name):
    return sk.parse_lag(os.path.join(ROOT, "lagrangians", name + ".lag"))


def unseen(name):
    return sk.parse_lag(os.path.join(ROOT, "tests", "models", "unseen", name + ".lag"))


def full_symbolic(model, disc, point):
    """All outputs by plain sympy.diff of the whole Ld, evaluated in 40 digits."""
    dl = sk.DiscreteLagrangian(model, disc)
    fn = sympy.lambdify(dl.arguments(), dl.outputs(), modules="mpmath")
    h, t0, t1, q0, q1, p = point
    with mpmath.workdps(40):
        return [float(mpmath.re(v)) for v in fn(*[mpmath.mpf(repr(x)) for x in [h, t0, t1] + q0 + q1 + p])]


def flatten(result):
    out = [result["Ld"]] + result["D1"] + result["D2"]
    for block in ("D11", "D12", "D22"):
        out += [x for row in result[block] for x in row]
    return out


class ExactValues(unittest.TestCase):
    def test_free_particle_trapezoid_is_the_exact_action_of_the_straight_line(self):
        ref = sk.ReferenceKernels(bundled("free_particle"), "trapezoid")
        h, q0, q1 = 0.25, [0.1, -0.3], [0.6, 0.4]
        out = ref.evaluate(h, 0.0, h, q0, q1, [])
        exact = ((q1[0] - q0[0]) ** 2 + (q1[1] - q0[1]) ** 2) / (2 * h)
        self.assertAlmostEqual(out["Ld"], exact, delta=1e-15 * exact)
        self.assertAlmostEqual(out["D12"][0][0], -1 / h, delta=1e-14)
        self.assertEqual(out["D12"][0][1], 0.0)

    def test_harmonic_midpoint_matches_its_formula(self):
        ref = sk.ReferenceKernels(bundled("harmonic"), "midpoint")
        h, x0, x1, omega = 0.2, 0.3, 0.5, 1.7
        out = ref.evaluate(h, 1.0, 1.2, [x0], [x1], [omega])
        v, xm = (x1 - x0) / h, (x0 + x1) / 2
        self.assertAlmostEqual(out["Ld"], h * (v * v / 2 - omega ** 2 * xm * xm / 2), delta=1e-15)
        self.assertAlmostEqual(out["D11"][0][0], 1 / h - h * omega ** 2 / 4, delta=1e-14)

    def test_spline_gauss2_integrates_a_cubic_exactly(self):
        # q(t) = c0 + c1 t + c2 t^2 + c3 t^3 per coordinate; int_0^h |q''|^2/2 dt in closed form.
        ref = sk.ReferenceKernels(bundled("spline"), "gauss2")
        h = 0.7
        cx, cy = (0.2, -1.0, 0.5, 0.3), (1.0, 0.4, -0.8, 1.1)
        pos = lambda c, t: c[0] + c[1] * t + c[2] * t * t + c[3] * t ** 3
        vel = lambda c, t: c[1] + 2 * c[2] * t + 3 * c[3] * t * t
        energy = lambda c: 2 * c[2] ** 2 * h + 6 * c[2] * c[3] * h ** 2 + 6 * c[3] ** 2 * h ** 3
        q0 = [pos(cx, 0), pos(cy, 0), vel(cx, 0), vel(cy, 0)]
        q1 = [pos(cx, h), pos(cy, h), vel(cx, h), vel(cy, h)]
        out = ref.evaluate(h, 0.0, h, q0, q1, [])
        exact = energy(cx) + energy(cy)
        self.assertAlmostEqual(out["Ld"], exact, delta=1e-14 * exact)

    def test_trapezoid_alpha_one_reproduces_the_seeds_hessian_for_the_spline(self):
        # For L = |q''|^2/2 the seed's eq. (trapezoidal) Hessian is exact, with W = identity.
        ref = sk.ReferenceKernels(bundled("spline"), "trapezoid(alpha=1)")
        h, a = 0.4, 3.0
        out = ref.evaluate(h, 0.0, h, [0.1, 0.2, 0.3, 0.4], [0.5, 0.1, -0.2, 0.7], [])
        self.assertAlmostEqual(out["D11"][0][0], 4 * a * a / h ** 3, delta=1e-10)
        self.assertAlmostEqual(out["D11"][0][2], 2 * a * a / h ** 2, delta=1e-10)
        self.assertAlmostEqual(out["D11"][2][2], (a * a + 1) / h, delta=1e-12)
        self.assertAlmostEqual(out["D12"][2][2], (a * a - 1) / h, delta=1e-12)
        self.assertAlmostEqual(out["D12"][0][0], -4 * a * a / h ** 3, delta=1e-10)


class DifferentiationPaths(unittest.TestCase):
    """The forward-mode reference against plain sympy.diff of the whole discrete Lagrangian."""

    CASES = [
        (bundled, "fuel_nav", "trapezoid", (0.1, 0.0, 0.1, [1.0, 2.0], [1.05, 2.1], [])),
        (bundled, "zermelo_tv", "trapezoid", (0.2, 1.0, 1.4, [1.0, 1.5], [1.1, 1.55], [0.8])),
        (unseen, "elastica", "gauss2", (0.2, 0.0, 0.2, [0.0, 0.0, 1.0, 0.1], [0.2, 0.03, 0.9, 0.2], [2.0, 100.0, 0.5])),
        (unseen, "elastica", "trapezoid(alpha=1)", (0.2, 0.0, 0.2, [0.0, 0.0, 1.0, 0.1], [0.2, 0.03, 0.9, 0.2],
                                                    [2.0, 100.0, 0.5])),
        (unseen, "function_zoo", "midpoint", (0.2, 0.3, 0.45, [0.3, -0.2], [0.35, -0.1], [0.7, 1.3])),
    ]

    def test_forward_mode_equals_plain_diff(self):
        for load, name, disc, point in self.CASES:
            with self.subTest(model=name, disc=disc):
                model = load(name)
                fast = flatten(sk.ReferenceKernels(model, disc).evaluate(*point))
                slow = full_symbolic(model, disc, point)
                scale = max(abs(x) for x in slow)
                self.assertLess(max(abs(a - b) for a, b in zip(fast, slow)) / scale, 1e-14)

    def test_gradient_matches_high_precision_central_differences(self):
        model = bundled("interp_fuel")
        dl = sk.DiscreteLagrangian(model, "gauss2")
        fn = sympy.lambdify(dl.arguments(), dl.action(), modules="mpmath")
        h, t0, t1 = 0.3, 2.0, 2.5
        q = [1.0, 2.0, 0.3, -0.2, 1.1, 1.9, 0.2, 0.1]
        out = sk.ReferenceKernels(model, "gauss2").evaluate(h, t0, t1, q[:4], q[4:], [50.0])
        grad = out["D1"] + out["D2"]
        with mpmath.workdps(50):
            eps = mpmath.mpf("1e-15")
            for i in range(8):
                plus = [mpmath.mpf(repr(x)) for x in q]
                minus = list(plus)
                plus[i] += eps
                minus[i] -= eps
                fd = (fn(h, t0, t1, *plus, 50) - fn(h, t0, t1, *minus, 50)) / (2 * eps)
                self.assertLess(abs(float(fd) - grad[i]), 1e-12 * max(1.0, abs(grad[i])))


class ParserErrors(unittest.TestCase):
    def error_of(self, text):
        with tempfile.NamedTemporaryFile("w", suffix=".lag", delete=False) as f:
            f.write(text)
        try:
            with self.assertRaises(sk.LagError) as ctx:
                sk.parse_lag(f.name)
            return str(ctx.exception).replace(f.name, "FILE")
        finally:
            os.unlink(f.name)

    def test_unknown_name_is_located(self):
        msg = self.error_of("model m\ncoords x\nL = x'^2 + bogus\n")
        self.assertTrue(msg.startswith("FILE:3:12: error: unknown name 'bogus'"), msg)

    def test_prime_on_a_param(self):
        msg = self.error_of("model m\ncoords x\nparam c = 2\nL = c'*x'\n")
        self.assertTrue(msg.startswith("FILE:4:5: error: only coordinates take primes"), msg)

    def test_derivative_above_the_order(self):
        msg = self.error_of("model m\ncoords x\nL = x''^2\n")
        self.assertTrue(msg.startswith("FILE:3:5: error: 'x''' exceeds the model's order 1"), msg)

    def test_bad_character(self):
        msg = self.error_of("model m\ncoords x\nL = x' $ 2\n")
        self.assertTrue(msg.startswith("FILE:3:8: error: unexpected character '$'"), msg)

    def test_missing_lagrangian(self):
        msg = self.error_of("model m\ncoords x\n")
        self.assertEqual(msg, "FILE: error: missing 'L = ...'")

    def test_unknown_statement(self):
        msg = self.error_of("model m\ncoords x\nlett a = 1\nL = x'^2\n")
        self.assertTrue(msg.startswith("FILE:3:1: error: unknown statement 'lett'"), msg)

    def test_undefined_discretization_for_the_order(self):
        model = sk.parse_lag(os.path.join(ROOT, "lagrangians", "spline.lag"))
        with self.assertRaises(sk.LagError):
            sk.DiscreteLagrangian(model, "midpoint")


if __name__ == "__main__":
    unittest.main()

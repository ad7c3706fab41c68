#!/usr/bin/python3
"""Adaptive grids against uniform ones on steep solutions: nodes and time for the same error.

Two problems, each with an exact solution:
- the boundary layer of tests/runtime/models/thin_layer.lag, eps x'' = x on [0, 1], x(0) = 1,
  x(1) = -0.5, with eps = 1e-4 and 1e-6 (layers of width 0.01 and 0.001 at both ends; exact motion
  in sinh): a uniform grid needs nodes in proportion to 1 / sqrt(eps), an adaptive one about as many
  for either;
- Troesch's problem of tests/runtime/models/troesch.lag, u'' = lambda sinh(lambda u) on [0, 1],
  u(0) = 0, u(1) = 1, with lambda = 8 (a front near t = 1); exact: with c = u'(0),
  t(u) = F(arctan(2 sinh(lambda u / 2) / c) | 1 - c^2 / 4) / lambda (F the incomplete elliptic
  integral of the first kind), c from t(1) = 1, u at a node by Newton on t(u).
For each discretization and requested accuracy: the adaptive solve (pardel.solve(accuracy=...),
Newton, rtol 1e-13, from N = 16), its grids, error estimate and true node error; then the smallest
uniform N (even) whose true node error is at most the adaptive solve's, found by doubling and
bisection, and the ratio of the two N. Times: the least of 3 calls, one thread, whole Python calls
(the adaptive one with all its grids; the uniform one with its error estimate).

  PYTHONPATH=build/python /usr/bin/python3 tools/benchmarks/adaptive_layer.py
"""
import math
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402
from scipy.special import ellipj, ellipkinc  # noqa: E402

import pardel  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODELS = os.path.join(ROOT, "tests", "runtime", "models")
LAG = os.path.join(MODELS, "thin_layer.lag")
EPSILONS = (1e-4, 1e-6)
LAMBDA = 8.0


def layer(eps):
    """The exact motion of eps x'' = x through x(0) = 1, x(1) = -0.5."""
    r = 1 / math.sqrt(eps)

    def exact(t):
        a = np.exp(-r * t) - np.exp(-r * (2 - t))
        b = np.exp(-r * (1 - t)) - np.exp(-r * (1 + t))
        return (a - 0.5 * b) / (1 - math.exp(-2 * r))
    return exact


class Troesch:
    """u'' = lam sinh(lam u), u(0) = 0, u(1) = 1, by its first integral u' = sqrt(c^2 + 4 sinh^2(lam u / 2))."""

    def __init__(self, lam):
        self.lam = lam
        self.c = brentq(lambda c: self.t_of(1.0, c) - 1.0, 1e-14, 2 - 1e-12, xtol=1e-300, rtol=1e-15, maxiter=500)

    def t_of(self, u, c=None):
        c = self.c if c is None else c
        return ellipkinc(np.arctan2(2 * np.sinh(self.lam * u / 2), c), 1 - c * c / 4) / self.lam

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        amplitude = ellipj(self.lam * t, 1 - self.c ** 2 / 4)[3]  # a start for Newton
        u = np.clip(2 / self.lam * np.arcsinh(self.c / 2 * np.tan(amplitude)), 0, 1)
        for _ in range(6):
            u = u - (self.t_of(u) - t) * np.sqrt(self.c ** 2 + 4 * np.sinh(self.lam * u / 2) ** 2)
        return np.where(t <= 0, 0.0, np.where(t >= 1, 1.0, u))


def timed(call, repeat=3):
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = call()
        best = min(best, time.perf_counter() - start)
    return best, result


def table(title, model, truth, common, cases):
    print("\n**%s**\n" % title)
    print("| discretization | accuracy | adaptive grids (N) | estimate | true error | time (s) | "
          "uniform N for that error | its time (s) | nodes ratio |")
    print("|---|---|---|---|---|---|---|---|---|")

    def error(r):
        return float(np.max(np.abs(r.q[:, 0] - truth(r.t))))
    for disc, accuracies in cases:
        for accuracy in accuracies:
            seconds, r = timed(lambda: pardel.solve(model, accuracy=accuracy, discretization=disc, **common))
            target = error(r)
            uniform = {}

            def err_at(N):
                if N not in uniform:
                    uniform[N] = error(pardel.solve(model, N=N, discretization=disc, **common))
                return uniform[N]
            hi = r.N + r.N % 2
            while err_at(hi) > target:
                hi *= 2
            lo = max(2, hi // 2)
            while hi - lo > 2:  # the smallest even N with error <= target lies in (lo, hi]
                mid = (lo + hi) // 2
                mid += mid % 2
                if mid >= hi:
                    break
                if err_at(mid) <= target:
                    hi = mid
                else:
                    lo = mid
            u_seconds, _ = timed(lambda: pardel.solve(model, N=hi, discretization=disc, **common))
            print("| `%s` | %.0e | %s | %.2e | %.2e | %.2e | %d | %.2e | %.1f |" % (
                disc, accuracy, ", ".join(str(n) for n in r.grid_sizes), r.error_estimate, target, seconds, hi,
                u_seconds, hi / r.N))
            sys.stdout.flush()


def main():
    for eps in EPSILONS:
        table("Boundary layer, eps = %g" % eps, pardel.model(LAG), layer(eps),
              dict(q0=[1.0], qN=[-0.5], T=1, params={"eps": eps}, method="newton", rtol=1e-13),
              (("trapezoid", [1e-6, 1e-8]), ("galerkin_gauss(s=2)", [1e-6, 1e-8]),
               ("galerkin_lobatto(s=3)", [1e-6, 1e-8])))
    table("Troesch's problem, lambda = %g" % LAMBDA, pardel.model(os.path.join(MODELS, "troesch.lag")), Troesch(LAMBDA),
          dict(q0=[0.0], qN=[1.0], T=1, params={"lambda": LAMBDA}, method="newton", rtol=1e-13),
          (("trapezoid", [1e-6]), ("galerkin_gauss(s=2)", [1e-6, 1e-8]), ("galerkin_gauss(s=4)", [1e-6, 1e-8])))
    return 0


if __name__ == "__main__":
    sys.exit(main())

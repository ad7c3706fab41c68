#!/usr/bin/python3
"""Adaptive grids against uniform ones on a boundary layer: nodes and time for the same error.

The model tests/runtime/models/thin_layer.lag, eps x'' = x with eps = 1e-4 on [0, 1], x(0) = 1,
x(1) = -0.5 (layers of width 0.01 at both ends; exact motion in sinh). For each discretization
and requested accuracy: the adaptive solve (pardel.solve(accuracy=...), Newton, rtol 1e-13, from
N = 16), its grids, error estimate and true node error; then the smallest uniform N (even) whose
true node error is at most the adaptive solve's, found by doubling and bisection, and the ratio of
the two N. Times: the least of 3 calls, one thread, whole Python calls (the adaptive one with all
its grids; the uniform one with its error estimate).

  PYTHONPATH=build/python /usr/bin/python3 tools/benchmarks/adaptive_layer.py
"""
import math
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import pardel  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
LAG = os.path.join(ROOT, "tests", "runtime", "models", "thin_layer.lag")
EPS = 1e-4
R = 1 / math.sqrt(EPS)


def exact(t):
    a = np.exp(-R * t) - np.exp(-R * (2 - t))
    b = np.exp(-R * (1 - t)) - np.exp(-R * (1 + t))
    return (a - 0.5 * b) / (1 - math.exp(-2 * R))


def timed(call, repeat=3):
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = call()
        best = min(best, time.perf_counter() - start)
    return best, result


def error(r):
    return float(np.max(np.abs(r.q[:, 0] - exact(r.t))))


def main():
    model = pardel.model(LAG)
    common = dict(q0=[1.0], qN=[-0.5], T=1, params={"eps": EPS}, method="newton", rtol=1e-13)
    print("| discretization | accuracy | adaptive grids (N) | estimate | true error | time (s) | "
          "uniform N for that error | its time (s) | nodes ratio |")
    print("|---|---|---|---|---|---|---|---|---|")
    for disc, accuracies in (("trapezoid", [1e-6]), ("galerkin_gauss(s=2)", [1e-6, 1e-9]),
                             ("galerkin_lobatto(s=3)", [1e-6, 1e-9])):
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
    return 0


if __name__ == "__main__":
    sys.exit(main())

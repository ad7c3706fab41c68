#!/usr/bin/python3
"""Work-precision: error against time for pardel's discretizations and scipy's solve_bvp.

Four problems with exact motions (models in tools/benchmarks/models/wp_*.lag):
  kepler  planar Kepler arc of the orbit a = 1, e = 0.3, t in [0.3, 2.0] (smooth, nonlinear);
  layer   eps x'' = x, eps = 1e-4, x(0) = 1, x(1) = 2 (boundary layers of width 0.01);
  driven  x'' + x = sin(2 t) on [0.7, 3.7] (short of the first conjugate point, t = pi) (time-dependent);
  beam    x'''' = x - t on [0.2, 2.7], an order-2 Lagrangian (x, x' fixed at both ends).
pardel: pardel.solve (Newton, rtol 1e-13) on uniform grids N = 2, 4, 8, ... for each
discretization the model lists; scipy: solve_bvp on the same first-order system at tol = 1e-3 ...
1e-10 from a 5-node mesh. The error of a solve is the largest |x - x_exact| of the coordinates'
values over its own nodes (pardel's grid, solve_bvp's final mesh); the time is the wall time of
the call (the least of at least `--repeat` calls, repeated until they took 0.2 s, at most 500;
one core: OMP_NUM_THREADS=1 is set here); for pardel
also the solve's own wall time (the least Result.wall_seconds of the calls: the solve with its
error estimate, without the Python call's scene and model set-up).
Writes docs/images/work_precision.csv and .png and prints one table per problem.

  PYTHONPATH=build/python /usr/bin/python3 tools/benchmarks/work_precision.py
  /usr/bin/python3 tools/benchmarks/work_precision.py --reuse     # table and chart from the CSV
"""
import argparse
import math
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from measured_rows import measured_or_reused  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODELS = os.path.join(ROOT, "tools", "benchmarks", "models")
IMAGES = os.path.join(ROOT, "docs", "images")
CSV = os.path.join(IMAGES, "work_precision.csv")


def kepler_exact(t):
    e = 0.3
    t = np.asarray(t, dtype=float)
    E = t.copy()
    for _ in range(60):
        E = E - (E - e * np.sin(E) - t) / (1 - e * np.cos(E))
    return np.stack([np.cos(E) - e, math.sqrt(1 - e * e) * np.sin(E)], axis=-1)


EPS = 1e-4
R = 1 / math.sqrt(EPS)


def layer_exact(t):
    t = np.asarray(t, dtype=float)
    # x = [sinh(r (1 - t)) + 2 sinh(r t)] / sinh(r), written with exponentials that do not overflow.
    a = np.exp(-R * t) - np.exp(-R * (2 - t))
    b = np.exp(-R * (1 - t)) - np.exp(-R * (1 + t))
    return ((a + 2 * b) / (1 - math.exp(-2 * R)))[..., None]


def driven_exact(t):
    t = np.asarray(t, dtype=float)
    return (0.8 * np.cos(t) - 0.4 * np.sin(t) - np.sin(2 * t) / 3)[..., None]


def beam_exact(t):
    t = np.asarray(t, dtype=float)
    return (np.cos(t) + np.sinh(t) + t)[..., None]


def beam_jet(t):
    return [math.cos(t) + math.sinh(t) + t, -math.sin(t) + math.cosh(t) + 1]


def problems():
    """name -> dict(lag, t0, T, q0, qN, exact, and the first-order system for solve_bvp)."""
    out = {}
    t0, T = 0.3, 1.7
    xa, xb = kepler_exact(t0), kepler_exact(t0 + T)
    out["kepler"] = dict(
        lag="wp_kepler.lag", t0=t0, T=T, q0=list(xa), qN=list(xb), exact=kepler_exact,
        fun=lambda t, y: np.vstack([y[2], y[3], -y[0] / (y[0] ** 2 + y[1] ** 2) ** 1.5,
                                    -y[1] / (y[0] ** 2 + y[1] ** 2) ** 1.5]),
        bc=lambda ya, yb: np.array([ya[0] - xa[0], ya[1] - xa[1], yb[0] - xb[0], yb[1] - xb[1]]),
        guess=lambda t: np.vstack([xa[0] + (xb[0] - xa[0]) * (t - t0) / T, xa[1] + (xb[1] - xa[1]) * (t - t0) / T,
                                   np.full_like(t, (xb[0] - xa[0]) / T), np.full_like(t, (xb[1] - xa[1]) / T)]))
    out["layer"] = dict(
        lag="wp_layer.lag", t0=0.0, T=1.0, q0=[1.0], qN=[2.0], exact=layer_exact,
        fun=lambda t, y: np.vstack([y[1], y[0] / EPS]),
        bc=lambda ya, yb: np.array([ya[0] - 1, yb[0] - 2]),
        guess=lambda t: np.vstack([1 + t, np.ones_like(t)]))
    t0, T = 0.7, 3.0
    da, db = driven_exact(t0)[0], driven_exact(t0 + T)[0]
    out["driven"] = dict(
        lag="wp_driven.lag", t0=t0, T=T, q0=[da], qN=[db], exact=driven_exact,
        fun=lambda t, y: np.vstack([y[1], -y[0] + np.sin(2 * t)]),
        bc=lambda ya, yb: np.array([ya[0] - da, yb[0] - db]),
        guess=lambda t: np.vstack([da + (db - da) * (t - 0.7) / 3.0, np.full_like(t, (db - da) / 3.0)]))
    t0, T = 0.2, 2.5
    ja, jb = beam_jet(t0), beam_jet(t0 + T)
    out["beam"] = dict(
        lag="wp_beam.lag", t0=t0, T=T, q0=ja, qN=jb, exact=beam_exact,
        fun=lambda t, y: np.vstack([y[1], y[2], y[3], y[0] - t]),
        bc=lambda ya, yb: np.array([ya[0] - ja[0], ya[1] - ja[1], yb[0] - jb[0], yb[1] - jb[1]]),
        guess=lambda t: np.vstack([ja[0] + (jb[0] - ja[0]) * (t - 0.2) / 2.5, np.full_like(t, (jb[0] - ja[0]) / 2.5),
                                   np.zeros_like(t), np.zeros_like(t)]))
    return out


def timed(call, repeat, inner=None, min_seconds=0.2, most=500):
    """The least wall time of at least `repeat` calls, repeated until they took `min_seconds`
    in all (at most `most` calls: the least time of a sub-millisecond call is stable only over
    many), the result of the last call, and the least of inner(result) (the solve's own time)
    over the calls."""
    best, best_inner, result = float("inf"), float("inf"), None
    calls, spent = 0, 0.0
    while calls < repeat or (spent < min_seconds and calls < most):
        start = time.perf_counter()
        result = call()
        took = time.perf_counter() - start
        best = min(best, took)
        spent += took
        calls += 1
        if inner is not None:
            best_inner = min(best_inner, inner(result))
    return best, result, best_inner


def run_pardel(name, prob, repeat, max_n):
    import pardel
    model = pardel.model(os.path.join(MODELS, prob["lag"]))
    rows = []
    for disc in model.discretizations:
        N, previous = 2, None
        while N <= max_n:
            call = lambda: pardel.solve(model, q0=prob["q0"], qN=prob["qN"], T=prob["T"], N=N, t0=prob["t0"],
                                        discretization=disc, method="newton", rtol=1e-13)
            seconds, r, solve_seconds = timed(call, repeat, lambda result: result.wall_seconds)
            n = len(prob["exact"](prob["t0"]))
            err = float(np.max(np.abs(np.asarray(r.q)[:, :n] - prob["exact"](np.asarray(r.t)))))
            rows.append(dict(problem=name, method="pardel " + disc, setting=N, nodes=N + 1, error=err,
                             seconds=seconds, solve_seconds=solve_seconds, status=r.status))
            if err < 1e-12 or (previous is not None and err > previous * 4 and err < 1e-9):
                break  # round-off reached
            previous = err
            N *= 2
    return rows


def run_scipy(name, prob, repeat):
    from scipy.integrate import solve_bvp
    rows = []
    for tol in [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]:
        def call():
            mesh = np.linspace(prob["t0"], prob["t0"] + prob["T"], 5)
            return solve_bvp(prob["fun"], prob["bc"], mesh, prob["guess"](mesh), tol=tol, max_nodes=200000)
        seconds, sol, _ = timed(call, repeat)
        n = len(prob["exact"](prob["t0"]))
        err = float(np.max(np.abs(sol.y[:n].T - prob["exact"](sol.x))))
        rows.append(dict(problem=name, method="scipy solve_bvp", setting=tol, nodes=len(sol.x), error=err,
                         seconds=seconds, solve_seconds=seconds,
                         status="converged" if sol.status == 0 else "status %d" % sol.status))
    return rows


def table(rows):
    for name in dict.fromkeys(r["problem"] for r in rows):
        print("\n### %s\n" % name)
        print("| method | N or tol | nodes | max error | call (s) | solve (s) | status |")
        print("|---|---|---|---|---|---|---|")
        for r in rows:
            if r["problem"] == name:
                print("| %s | %s | %s | %.2e | %.2e | %.2e | %s |" % (
                    r["method"], r["setting"], r["nodes"], float(r["error"]), float(r["seconds"]),
                    float(r["solve_seconds"]), r["status"]))
        # Time to reach each error level: the least time of a solve with error at most the level.
        print("\n| error level | " + " | ".join(dict.fromkeys(r["method"] for r in rows if r["problem"] == name)) + " |")
        methods = list(dict.fromkeys(r["method"] for r in rows if r["problem"] == name))
        print("|---|" + "---|" * len(methods))
        for level in [1e-4, 1e-6, 1e-8, 1e-10]:
            cells = []
            for m in methods:
                ok = [(float(r["seconds"]), float(r["solve_seconds"])) for r in rows
                      if r["problem"] == name and r["method"] == m and float(r["error"]) <= level
                      and r["status"] == "converged"]
                if not ok:
                    cells.append("–")
                elif m.startswith("scipy"):
                    cells.append("%.2e" % min(ok)[0])
                else:
                    cells.append("%.2e (%.1e)" % min(ok))
            print("| %.0e | %s |" % (level, " | ".join(cells)))


def chart(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(dict.fromkeys(r["problem"] for r in rows))
    fig, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 4), squeeze=False)
    for ax, name in zip(axes[0], names):
        for m in dict.fromkeys(r["method"] for r in rows if r["problem"] == name):
            sel = [r for r in rows if r["problem"] == name and r["method"] == m]
            ax.loglog([float(r["error"]) for r in sel], [float(r["seconds"]) for r in sel],
                      "o--" if m.startswith("scipy") else "o-", ms=3, label=m.replace("pardel ", ""))
        ax.set_title(name)
        ax.set_xlabel("max node error")
        ax.invert_xaxis()
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("wall time of the call (s)")
    axes[0][-1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reuse", action="store_true", help="table and chart from the CSV")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--max-n", type=int, default=1 << 16)
    parser.add_argument("--problems", default="kepler,layer,driven,beam")
    args = parser.parse_args()
    def measure():
        rows, probs = [], problems()
        for name in args.problems.split(","):
            rows += run_pardel(name, probs[name], args.repeat, args.max_n)
            rows += run_scipy(name, probs[name], args.repeat)
        return rows
    rows = measured_or_reused(CSV, measure, args.reuse)
    table(rows)
    chart(rows, os.path.join(IMAGES, "work_precision.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())

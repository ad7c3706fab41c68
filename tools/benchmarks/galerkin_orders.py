#!/usr/bin/python3
"""Measured global orders of the Galerkin discretizations, s = 1 ... 8, Gauss and Lobatto.

Three problems with exact motions (models in tools/benchmarks/models/go_*.lag):
  kepler      planar Kepler arc of the orbit a = 1, e = 0.3, t in [0.3, 2.0] (Kepler's equation);
  oscillator  x'' = -4 x on [0, 1.2], x = cos 2t + 0.5 sin 2t;
  geodesic    the unit sphere in polar angles along the great circle tilted by 0.6 rad from the
              equator, arc length in [0.2, 1.4].
Each is solved by pardel.solve (Newton, rtol 1e-14) from the straight line for N = 2 ... 64. The
error is the largest |x_k - x(t_k)| over the nodes and coordinates. The observed order is the
slope of log error against log N fitted from the smallest N up to the last N whose error is above
1e-12 (round-off takes over near 1e-14 to 1e-13 on these problems), and also the last local slope
of that range. Writes docs/images/galerkin_orders.csv and .png; prints the tables of
docs/discretizations.md.

  PYTHONPATH=build/python /usr/bin/python3 tools/benchmarks/galerkin_orders.py
  /usr/bin/python3 tools/benchmarks/galerkin_orders.py --reuse
"""
import argparse
import math
import os
import sys

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from measured_rows import measured_or_reused  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODELS = os.path.join(ROOT, "tools", "benchmarks", "models")
IMAGES = os.path.join(ROOT, "docs", "images")
CSV = os.path.join(IMAGES, "galerkin_orders.csv")
NS = [2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64]
FLOOR = 1e-12


def kepler(t):
    e = 0.3
    t = np.asarray(t, dtype=float)
    E = t.copy()
    for _ in range(60):
        E = E - (E - e * np.sin(E) - t) / (1 - e * np.cos(E))
    return np.stack([np.cos(E) - e, math.sqrt(1 - e * e) * np.sin(E)], axis=-1)


def oscillator(t):
    t = np.asarray(t, dtype=float)
    return (np.cos(2 * t) + 0.5 * np.sin(2 * t))[..., None]


def geodesic(s):
    s = np.asarray(s, dtype=float)
    a = 0.6
    x, y, z = np.cos(s), np.sin(s) * np.cos(a), np.sin(s) * np.sin(a)
    return np.stack([np.arccos(z), np.arctan2(y, x)], axis=-1)


PROBLEMS = {
    "kepler": ("go_kepler.lag", 0.3, 1.7, kepler),
    "oscillator": ("go_oscillator.lag", 0.0, 1.2, oscillator),
    "geodesic": ("go_geodesic.lag", 0.2, 1.2, geodesic),
}


def measure():
    import pardel
    rows = []
    for name, (lag, t0, T, exact) in PROBLEMS.items():
        model = pardel.model(os.path.join(MODELS, lag))
        for disc in model.discretizations:
            for N in NS:
                r = pardel.solve(model, q0=list(exact(t0)), qN=list(exact(t0 + T)), T=T, N=N, t0=t0,
                                 discretization=disc, method="newton", rtol=1e-14)
                err = float(np.max(np.abs(np.asarray(r.q) - exact(np.asarray(r.t)))))
                rows.append(dict(problem=name, discretization=disc, N=N, error=err, status=r.status))
                print(name, disc, N, "%.3e" % err, r.status, file=sys.stderr)
    return rows


def fit(series):
    """(slope over the range above FLOOR, last local slope, last N of the range) or None."""
    pts = []
    for N, e in series:
        if e < FLOOR:
            break
        pts.append((N, e))
    if len(pts) < 2:
        return None
    x = np.log([p[0] for p in pts])
    y = np.log([p[1] for p in pts])
    slope = -np.polyfit(x, y, 1)[0]
    local = -(y[-1] - y[-2]) / (x[-1] - x[-2])
    return slope, local, pts[-1][0], pts[-1][1]


def report(rows):
    print("| problem | discretization | order 2s | fitted slope | last local slope | range | error at end of range | error at N = 4 |")
    print("|---|---|---|---|---|---|---|---|")
    for name in PROBLEMS:
        for disc in dict.fromkeys(r["discretization"] for r in rows if r["problem"] == name):
            series = [(int(r["N"]), float(r["error"])) for r in rows if r["problem"] == name and r["discretization"] == disc]
            s = int(disc.split("s=")[1].rstrip(")"))
            e4 = dict(series)[4]
            f = fit(series)
            if f is None:
                print("| %s | `%s` | %d | – | – | error below %.0e from N = 2 | – | %.1e |" % (name, disc, 2 * s, FLOOR, e4))
            else:
                slope, local, last, elast = f
                print("| %s | `%s` | %d | %.2f | %.2f | N = 2–%d | %.1e | %.1e |" % (name, disc, 2 * s, slope, local, last,
                                                                                   elast, e4))


def chart(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for ax, name in zip(axes, PROBLEMS):
        for disc in dict.fromkeys(r["discretization"] for r in rows if r["problem"] == name):
            if "gauss" not in disc:
                continue
            sel = [r for r in rows if r["problem"] == name and r["discretization"] == disc]
            ax.loglog([int(r["N"]) for r in sel], [max(float(r["error"]), 1e-17) for r in sel], "o-", ms=3,
                      label=disc.replace("galerkin_", ""))
        ax.set_title(name + " (Gauss)")
        ax.set_xlabel("N")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("max node error")
    axes[-1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reuse", action="store_true", help="tables and chart from the CSV")
    args = parser.parse_args()
    rows = measured_or_reused(CSV, measure, args.reuse)
    report(rows)
    chart(rows, os.path.join(IMAGES, "galerkin_orders.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())

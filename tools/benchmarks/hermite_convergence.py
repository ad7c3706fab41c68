#!/usr/bin/python3
"""Global error against N of every hermite_gauss(s=S) discretization at orders 3 and 4.

Solves two linear test problems with Newton through the pardel CLI and compares the nodes with
the closed-form solution:
  order 3: tools/benchmarks/models/conv_jerk_spring.lag, L = (x'''^2 + x^2)/2, x = cosh t;
  order 4: tools/benchmarks/models/conv_snap_spring.lag, L = (x''''^2 + x^2)/2,
           x = Re exp(r t), r = exp(i pi/8),
both on [0, 5] with the exact jets fixed at both ends. Writes docs/images/conv_hermite.csv and
docs/images/conv_hermite.png, and prints each error and the slope of log error against log N fitted
over the N before the round-off floor, next to the consistency order pardel-gen reports.

  /usr/bin/python3 tools/benchmarks/hermite_convergence.py --build build
  /usr/bin/python3 tools/benchmarks/hermite_convergence.py --reuse     # table and chart from the CSV
"""
import argparse
import cmath
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODELS = os.path.join(ROOT, "tools", "benchmarks", "models")
IMAGES = os.path.join(ROOT, "docs", "images")
T = 5.0

# order -> (model file, exact jet function of (k, t))
PROBLEMS = {
    3: ("conv_jerk_spring.lag", lambda k, t: math.cosh(t) if k % 2 == 0 else math.sinh(t)),
    4: ("conv_snap_spring.lag",
        lambda k, t: (cmath.exp(1j * math.pi / 8) ** k * cmath.exp(cmath.exp(1j * math.pi / 8) * t)).real),
}
JET_KEYS = ["q", "v", "a", "j"]
DEFAULT_N = [3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 14, 16, 20, 24, 28, 32, 40, 48, 64, 80, 96, 128, 160, 240, 320, 480, 640, 800,
             1000]


def discretizations(build, lag):
    """(name, consistency_order) of every discretization pardel-gen generates for the .lag file."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "ir.json")
        subprocess.run([os.path.join(build, "pardel-gen"), lag, "-o", out], check=True,
                       stdout=subprocess.DEVNULL)
        with open(out) as f:
            ir = json.load(f)
    return [(d["name"], d["consistency_order"]) for d in ir["discretizations"]]


def write_scene(path, order, disc):
    """A scene for the order's test problem with the exact jets at t = 0 and t = T."""
    lag, exact = PROBLEMS[order]
    lines = [f'model = "{os.path.join(MODELS, lag)}"', f'discretization = "{disc}"', "",
             "[grid]", f"T = {T!r}", "N = 10", "", "[boundary]"]
    for end, t in (("0", 0.0), ("N", T)):
        for k in range(order):
            lines.append(f"{JET_KEYS[k]}{end} = [{exact(k, t)!r}]")
    lines += ["", "[guess]", 'kind = "linear"', ""]
    with open(path, "w") as f:
        f.write("\n".join(lines))


def solve(build, scene, out, sets):
    """Runs pardel solve; returns (exit status, summary dict, trajectory rows), or (exit status,
    {"status": first line of the error}, None) when the solve wrote nothing (a refused scene)."""
    cmd = [os.path.join(build, "pardel"), "solve", scene, "--quiet", "--no-plot", "--out", out]
    for s in sets:
        cmd += ["--set", s]
    p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    rc = p.returncode
    if not os.path.exists(os.path.join(out, "summary.json")):
        return rc, {"status": "refused: " + p.stderr.strip().splitlines()[0].split("error: ")[-1][:90]}, None
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    with open(os.path.join(out, "trajectory.csv")) as f:
        rows = list(csv.DictReader(f))
    return rc, summary, rows


def fit_window(Ns, errs, floor_factor):
    """Indices of the points used in the fit: from the first N on, up to the last point whose error
    is above floor_factor times the smallest error of the series (the round-off floor) and before
    the error first fails to decrease."""
    floor = min(errs)
    idx = []
    for i, e in enumerate(errs):
        if e <= floor_factor * floor or (i > 0 and e >= errs[i - 1]):
            break
        idx.append(i)
    return idx


def slope(Ns, errs, idx):
    xs = [math.log(Ns[i]) for i in idx]
    ys = [math.log(errs[i]) for i in idx]
    if len(xs) < 2:
        return float("nan")
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def measure(build, Ns):
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for order, (lag, exact) in PROBLEMS.items():
            for disc, cons in discretizations(build, os.path.join(MODELS, lag)):
                scene = os.path.join(tmp, "scene.toml")
                write_scene(scene, order, disc)
                for N in Ns:
                    out = os.path.join(tmp, f"o{order}_{N}")
                    rc, summ, traj = solve(build, scene, out,
                                           [f"grid.N={N}", "solver.method=newton", "solver.rtol=1e-15"])
                    if traj is None:
                        err = float("nan")
                    else:
                        err = max(abs(float(r["x"]) - exact(0, float(r["t"]))) for r in traj)
                    rows.append({"order": order, "discretization": disc, "consistency_order": cons, "N": N,
                                 "max_node_error": err, "status": summ["status"],
                                 "iterations": summ.get("iterations", ""), "residual": summ.get("residual", "")})
                    print(f"  order {order} {disc:20s} N = {N:4d}: error {err:.3e} ({summ['status']}, rc {rc})",
                          file=sys.stderr, flush=True)
    return rows


def series(rows):
    out = {}
    for r in rows:
        if math.isnan(float(r["max_node_error"])):
            continue
        out.setdefault((int(r["order"]), r["discretization"], int(r["consistency_order"])), []).append(
            (int(r["N"]), float(r["max_node_error"])))
    return out


def report_and_plot(rows, floor_factor, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    print("| order | discretization | consistency order | fitted slope | fit range | last local slope | error at end of fit | floor (smallest error, at N) |")
    print("|---|---|---|---|---|---|---|---|")
    for (order, disc, cons), pts in series(rows).items():
        Ns = [p[0] for p in pts]
        errs = [p[1] for p in pts]
        idx = fit_window(Ns, errs, floor_factor)
        s = slope(Ns, errs, idx)
        imin = min(range(len(errs)), key=lambda i: errs[i])
        rng = f"N = {Ns[idx[0]]}–{Ns[idx[-1]]}" if idx else "-"
        end = f"{errs[idx[-1]]:.1e}" if idx else "-"
        loc = (math.log(errs[idx[-2]] / errs[idx[-1]]) / math.log(Ns[idx[-1]] / Ns[idx[-2]])
               if len(idx) > 1 else float("nan"))
        loc_s = f"{loc:.2f} (N = {Ns[idx[-2]]}→{Ns[idx[-1]]})" if len(idx) > 1 else "-"
        print(f"| {order} | `{disc}` | {cons} | {-s:.2f} | {rng} | {loc_s} | {end} | {errs[imin]:.1e} (N = {Ns[imin]}) |")
        ax = axes[0 if order == 3 else 1]
        line, = ax.loglog(Ns, errs, "o-", ms=3, label=f"{disc}: slope {-s:.2f}")
        if idx:
            ax.loglog([Ns[i] for i in idx], [errs[i] for i in idx], "o", ms=6, mfc="none", color=line.get_color())
    for ax, order in zip(axes, (3, 4)):
        ax.set_title(f"order {order}: " + ("(x'''² + x²)/2, x = cosh t" if order == 3
                                          else "(x''''² + x²)/2, x = Re exp(t·e^(iπ/8))"))
        ax.set_xlabel("N (T = 5)")
        ax.set_ylabel("max node error of x")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Newton solves, rtol 1e-15; circled points: the fit (before the round-off floor)")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    print(f"chart: {os.path.relpath(png, ROOT)}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"), help="folder with pardel and pardel-gen")
    ap.add_argument("--N", default=",".join(map(str, DEFAULT_N)), help="comma-separated grid sizes")
    ap.add_argument("--floor-factor", type=float, default=30.0,
                    help="the fit stops before the error comes within this factor of the smallest error")
    ap.add_argument("--reuse", action="store_true", help="table and chart from the existing CSV")
    args = ap.parse_args()
    csv_path = os.path.join(IMAGES, "conv_hermite.csv")
    png = os.path.join(IMAGES, "conv_hermite.png")
    if args.reuse:
        with open(csv_path) as f:
            rows = list(csv.DictReader(f))
    else:
        rows = measure(os.path.abspath(args.build), [int(n) for n in args.N.split(",")])
        with open(csv_path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)
    report_and_plot(rows, args.floor_factor, png)


if __name__ == "__main__":
    main()

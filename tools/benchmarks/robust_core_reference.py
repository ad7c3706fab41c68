#!/usr/bin/python3
"""Independent SciPy references for the robust-core benchmark's three problems.

For each scene in tools/benchmarks/scenes/ (rb_kepler, rb_double_pendulum, rb_min_accel) this
solves the continuous problem with SciPy, solves the scene with `pardel solve` at N and 2N
(only `grid.N`, one thread, plus any --set given here), and prints the largest deviation of
pardel's nodes from the continuous solution and the difference of the actions. A consistent
second-order discretization shows deviations O(h^2): about 4 times smaller at 2N.

References:
  rb_kepler, rb_double_pendulum: scipy.integrate.solve_bvp on the continuous Euler-Lagrange
      equations (first-order system in q, q'), then polished by shooting (solve_ivp, DOP853,
      rtol 1e-13, on the initial velocity) so that the reference's own error is far below
      the discretization's; the action is integrated along the shooting solution.
  rb_min_accel: exact: the clamped C2 cubic spline through the knots
      (scipy.interpolate.CubicSpline, bc_type = end velocities), action 1/2 int |q''|^2 exactly.

Usage:
  /usr/bin/python3 tools/benchmarks/robust_core_reference.py --build build [--N 800]
        [--set solver.method=newton ...] [--only rb_kepler,...]
Exit status 0 when every pardel run converged (exit code 0 or 7 "stalled", i.e. converged to
the round-off level) and every deviation is below --max-dev (default 1e-3); 1 otherwise.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import tomllib

import numpy as np
from scipy.integrate import solve_bvp, solve_ivp
from scipy.interpolate import CubicSpline
from scipy.optimize import root

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SCENES = ["rb_kepler", "rb_double_pendulum", "rb_min_accel"]


def read_scene(name):
    path = os.path.join(HERE, "scenes", name + ".toml")
    with open(path, "rb") as f:
        return path, tomllib.load(f)


# ---------------------------------------------------------------------------------------------
# Continuous Euler-Lagrange equations as first-order systems y = (q, q')

def kepler_rhs(params):
    mu = params.get("mu", 1.0)

    def f(t, y):
        x, yy, vx, vy = y
        r3 = (x * x + yy * yy) ** 1.5
        return np.array([vx, vy, -mu * x / r3, -mu * yy / r3])

    def lagrangian(y):
        x, yy, vx, vy = y
        return 0.5 * (vx * vx + vy * vy) + mu / np.sqrt(x * x + yy * yy)

    return f, lagrangian


def double_pendulum_rhs(params):
    g = params.get("g", 1.0)

    def f(t, y):
        a, b, da, db = y
        c, s = np.cos(a - b), np.sin(a - b)
        # [[2, c], [c, 1]] (a'', b'') = (-b'^2 s - 2 g sin a, a'^2 s - g sin b)
        r1 = -db * db * s - 2 * g * np.sin(a)
        r2 = da * da * s - g * np.sin(b)
        det = 2 - c * c
        dda = (r1 - c * r2) / det
        ddb = (2 * r2 - c * r1) / det
        return np.array([da, db, dda, ddb])

    def lagrangian(y):
        a, b, da, db = y
        return da * da + 0.5 * db * db + da * db * np.cos(a - b) + g * (2 * np.cos(a) + np.cos(b))

    return f, lagrangian


def second_order_reference(scene, rhs):
    """solve_bvp on q'' = F(q, q') with fixed ends, then a shooting polish. Returns
    (q(t) for an array t -> (n, ncoords), velocity function, action, info)."""
    params = scene.get("params", {})
    f, lagrangian = rhs(params)
    t0 = scene["grid"].get("t0", 0.0)
    T = scene["grid"]["T"]
    q0 = np.array(scene["boundary"]["q0"], float)
    qN = np.array(scene["boundary"]["qN"], float)
    d = len(q0)
    tt = np.linspace(t0, t0 + T, 201)
    guess = np.vstack([q0[:, None] + (qN - q0)[:, None] * (tt - t0) / T,
                       np.repeat(((qN - q0) / T)[:, None], tt.size, axis=1)])

    def fv(t, Y):
        return np.column_stack([f(ti, Y[:, i]) for i, ti in enumerate(t)])

    def bc(ya, yb):
        return np.concatenate([ya[:d] - q0, yb[:d] - qN])

    bvp = solve_bvp(fv, bc, tt, guess, tol=1e-9, max_nodes=200000)
    if not bvp.success:
        raise RuntimeError("solve_bvp: " + bvp.message)

    # shooting polish on the initial velocity
    def end_miss(v0):
        s = solve_ivp(f, (t0, t0 + T), np.concatenate([q0, v0]), method="DOP853", rtol=1e-13, atol=1e-14)
        return s.y[:d, -1] - qN

    sol = root(end_miss, bvp.sol(t0)[d:], tol=1e-14)
    v0 = sol.x
    shoot = solve_ivp(f, (t0, t0 + T), np.concatenate([q0, v0]), method="DOP853", rtol=1e-13, atol=1e-14,
                      dense_output=True)
    # action: Simpson on a fine grid of the dense solution
    tf = np.linspace(t0, t0 + T, 20001)
    Lf = lagrangian(shoot.sol(tf))
    hf = tf[1] - tf[0]
    action = hf / 3 * (Lf[0] + Lf[-1] + 4 * Lf[1:-1:2].sum() + 2 * Lf[2:-1:2].sum())
    bvp_vs_shoot = float(np.max(np.abs(bvp.sol(tf)[:d] - shoot.sol(tf)[:d])))
    info = "solve_bvp (%d nodes) vs shooting polish: %.1e" % (bvp.x.size, bvp_vs_shoot)
    return (lambda t: shoot.sol(t)[:d].T), (lambda t: shoot.sol(t)[d:].T), action, info


def spline_reference(scene):
    t0 = scene["grid"].get("t0", 0.0)
    T = scene["grid"]["T"]
    b = scene["boundary"]
    knots = sorted(scene.get("knots", []), key=lambda k: k["t"])
    ts = [t0] + [k["t"] for k in knots] + [t0 + T]
    qs = [b["q0"]] + [k["q"] for k in knots] + [b["qN"]]
    cs = CubicSpline(np.array(ts, float), np.array(qs, float), axis=0,
                     bc_type=((1, np.array(b["v0"], float)), (1, np.array(b["vN"], float))))
    # 1/2 int |q''|^2: q'' is linear on each piece, so Simpson on each piece is exact
    action = 0.0
    for i in range(len(ts) - 1):
        a, c = ts[i], ts[i + 1]
        m = 0.5 * (a + c)
        qa, qm, qc = cs(a, 2), cs(m, 2), cs(c, 2)
        action += 0.5 * (c - a) / 6 * (qa @ qa + 4 * (qm @ qm) + qc @ qc)
    return (lambda t: cs(t)), (lambda t: cs(t, 1)), action, "exact clamped cubic spline"


def reference(name, scene):
    if name == "rb_kepler":
        return second_order_reference(scene, kepler_rhs)
    if name == "rb_double_pendulum":
        return second_order_reference(scene, double_pendulum_rhs)
    if name == "rb_min_accel":
        return spline_reference(scene)
    raise ValueError(name)


# ---------------------------------------------------------------------------------------------

def run_pardel(build, scene_path, N, sets, out):
    cmd = [os.path.join(build, "pardel"), "solve", scene_path, "--set", "grid.N=%d" % N,
           "--set", "solver.threads=1"]
    for s in sets:
        cmd += ["--set", s]
    cmd += ["--out", out, "--quiet", "--no-plot"]
    rc = subprocess.run(cmd, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True).returncode
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    with open(os.path.join(out, "trajectory.csv")) as f:
        rows = list(csv.reader(f))
    header, data = rows[0], np.array(rows[1:], float)
    return rc, summary, header, data


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--N", type=int, default=800, help="moderate N (divisible by 4; also run at 2N)")
    ap.add_argument("--set", action="append", default=[], help="extra pardel --set KEY=VALUE (repeatable)")
    ap.add_argument("--only", default="", help="comma-separated scene names")
    ap.add_argument("--max-dev", type=float, default=1e-3)
    args = ap.parse_args()
    build = os.path.abspath(os.path.join(REPO, args.build)) if not os.path.isabs(args.build) else args.build
    names = [n for n in args.only.split(",") if n] or SCENES
    ok = True
    print("| problem | N | pardel status | iterations | max node deviation | max velocity deviation (order 1: interior) "
          "| action (pardel) | action (reference) | action difference |")
    print("|---|---|---|---|---|---|---|---|---|")
    notes = []
    with tempfile.TemporaryDirectory(prefix="robust_core_ref_") as tmp:
        for name in names:
            path, scene = read_scene(name)
            qfun, vfun, action_ref, info = reference(name, scene)
            notes.append("%s: %s; reference action %.12g" % (name, info, action_ref))
            ncoords = len(scene["boundary"]["q0"])
            devs = []
            for N in (args.N, 2 * args.N):
                out = os.path.join(tmp, "%s_%d" % (name, N))
                rc, summary, header, data = run_pardel(build, path, N, args.set, out)
                t = data[:, 1]
                q = data[:, 2:2 + ncoords]
                dev = float(np.max(np.abs(q - qfun(t))))
                vdev = ""
                if data.shape[1] >= 2 + 2 * ncoords:
                    # order 2: the velocities are unknowns of the discrete problem; order 1:
                    # trajectory.csv's central differences, compared at interior nodes only
                    # (the end nodes hold one-sided differences, O(h))
                    v = data[:, 2 + ncoords:2 + 2 * ncoords]
                    inner = slice(None) if "v0" in scene["boundary"] else slice(1, -1)
                    vdev = "%.2e" % float(np.max(np.abs(v[inner] - vfun(t[inner]))))
                devs.append(dev)
                da = summary["action"] - action_ref
                print("| %s | %d | %s (exit %d) | %d | %.2e | %s | %.12g | %.12g | %.2e |" % (
                    name, N, summary["status"], rc, summary["iterations"], dev, vdev, summary["action"],
                    action_ref, da))
                if rc not in (0, 7) or not dev < args.max_dev:
                    ok = False
            notes.append("%s: deviation ratio N -> 2N: %.2f (4 for O(h^2))" % (name, devs[0] / devs[1]))
    print()
    for n in notes:
        print("- " + n)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

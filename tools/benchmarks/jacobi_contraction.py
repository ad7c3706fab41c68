#!/usr/bin/python3
"""Contraction of Jacobi-Newton against N at orders 3 and 4, next to Newton at the same N.

The problems are those of hermite_convergence.py (L = (x'''^2 + x^2)/2 and (x''''^2 + x^2)/2 on
[0, 5], exact end jets, straight-line guess), discretized by hermite_gauss(s = order). For each N:
  - 1 - rho_check: what `pardel check` reports (certificate.jacobi_one_minus_rho, by inverse
    iteration at the guess), or its round-off level where it says that 1 - rho is not resolved;
  - rho_eig: the same radius from the assembled Hessian: the Lagrangian is quadratic, so the blocks
    D11, D12, D22 that `pardel kernels` returns are the same on every interval; H is assembled
    (free nodes 1..N-1), each node's jet scaled by h^k (which leaves J = -D^-1 C unchanged) and
    1 - rho = smallest eigenvalue of D^-1/2 H D^-1/2 computed by numpy (double precision: 40-digit
    eigenvalues of the same matrices agree to 7 digits at N = 20; the fit uses values above 1e-14);
  - rho_hist: the mean residual ratio per sweep over the last half of a Jacobi-Newton solve capped
    at --sweeps sweeps (from the sweep numbers and residuals in its convergence.csv);
  - the sweeps predicted from the guess's residual r0 to the Newton solve's tolerance,
    log(tol/r0)/log(rho), and Newton's iterations and wall time.
Fits 1 - rho ~ N^-p. Writes docs/images/jacobi_contraction.csv and .png and prints the table.

  /usr/bin/python3 tools/benchmarks/jacobi_contraction.py --build build
  /usr/bin/python3 tools/benchmarks/jacobi_contraction.py --reuse     # table and chart from the CSV
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hermite_convergence as hc  # noqa: E402  (the test problems and the scene writer)

IMAGES = hc.IMAGES
ROOT = hc.ROOT
DEFAULT_N = [10, 14, 20, 28, 40, 56, 80, 113, 160]


def check(build, scene, N):
    p = subprocess.run([os.path.join(build, "pardel"), "check", scene, "--set", f"grid.N={N}", "--json"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        j = json.loads(p.stdout)
    except json.JSONDecodeError:
        return None, None, None, None, p.stderr.strip().splitlines()[0][:100]
    c = j["certificate"]
    return j["residual"], c["jacobi_one_minus_rho"], c["jacobi_one_minus_rho_roundoff"], c["spectral_radius_resolved"], ""


def one_minus_rho_eig(build, order, disc, N):
    """1 - rho of block Jacobi from the assembled, scaled Hessian (see the module's comment)."""
    lag = os.path.join(hc.MODELS, hc.PROBLEMS[order][0])
    h = hc.T / N
    zero = ",".join(["0"] * order)
    p = subprocess.run([os.path.join(build, "pardel"), "kernels", "--model", lag, "--disc", disc, "--h", repr(h),
                        "--t0", "0", "--t1", repr(h), "--q0", zero, "--q1", zero],
                       stdout=subprocess.PIPE, text=True, check=True)
    k = json.loads(p.stdout)
    s = np.array([h ** i for i in range(order)])
    S = np.diag(s)
    D11, D12, D22 = (S @ np.array(k[name]) @ S for name in ("D11", "D12", "D22"))
    m = N - 1
    H = np.zeros((m * order, m * order))
    for i in range(m):
        H[i * order:(i + 1) * order, i * order:(i + 1) * order] = D22 + D11
        if i + 1 < m:
            H[i * order:(i + 1) * order, (i + 1) * order:(i + 2) * order] = D12
            H[(i + 1) * order:(i + 2) * order, i * order:(i + 1) * order] = D12.T
    w, V = np.linalg.eigh(D22 + D11)
    Dm12 = V @ np.diag(w ** -0.5) @ V.T
    B = np.kron(np.eye(m), Dm12)
    ev = np.linalg.eigvalsh(B @ H @ B)
    # eigenvalues of J are 1 - ev; rho = max |1 - ev|
    return min(ev[0], 2 - ev[-1])


def solve(build, scene, out, sets):
    rc, summ, _ = hc.solve(build, scene, out, sets)
    hist = []
    path = os.path.join(out, "convergence.csv")
    if os.path.exists(path):
        with open(path) as f:
            hist = [(int(r["iteration"]), float(r["residual"])) for r in csv.DictReader(f)]
    return rc, summ, hist


def measure(build, Ns, sweeps):
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for order in hc.PROBLEMS:
            disc = f"hermite_gauss(s={order})"
            scene = os.path.join(tmp, f"scene{order}.toml")
            hc.write_scene(scene, order, disc)
            for N in Ns:
                r0, omr_check, omr_roundoff, resolved, err = check(build, scene, N)
                rc, ns, _ = solve(build, scene, os.path.join(tmp, f"n{order}_{N}"),
                                  [f"grid.N={N}", "solver.method=newton"])
                rcj, js, hist = solve(build, scene, os.path.join(tmp, f"j{order}_{N}"),
                                      [f"grid.N={N}", "solver.method=jacobi-newton", f"solver.max_iterations={sweeps}"])
                rho_hist = float("nan")
                if len(hist) > 10:
                    # convergence.csv thins long histories: use the sweep numbers it records
                    last_it, last_r = hist[-1]
                    a_it, a_r = min(hist, key=lambda p: abs(p[0] - last_it / 2))
                    rho_hist = (last_r / a_r) ** (1.0 / (last_it - a_it))
                try:
                    omr = one_minus_rho_eig(build, order, disc, N)
                except Exception as e:  # noqa: BLE001
                    omr, err = float("nan"), err or str(e)[:100]
                tol = ns.get("tolerance", float("nan"))
                pred = (math.log(tol / r0) / math.log1p(-omr)) if (r0 and omr > 0 and tol == tol) else float("nan")
                row = {"order": order, "discretization": disc, "N": N,
                       "newton_status": ns["status"], "newton_iterations": ns.get("iterations", ""),
                       "newton_seconds": ns.get("wall_seconds", ""),
                       "tol": tol, "r0": r0 if r0 is not None else "",
                       "one_minus_rho_check": omr_check if omr_check is not None else float("nan"),
                       "check_roundoff": omr_roundoff if omr_roundoff is not None else float("nan"),
                       "check_resolved": int(bool(resolved)),
                       "one_minus_rho_eig": omr, "predicted_sweeps": pred,
                       "jn_sweeps": js.get("iterations", ""), "jn_status": js["status"],
                       "jn_final_residual": js.get("residual", ""), "rho_hist": rho_hist, "note": err}
                rows.append(row)
                print(f"  order {order} N = {N}: 1-rho check {row['one_minus_rho_check']:.3e} eig {omr:.3e} "
                      f"hist {1 - rho_hist:.3e}; newton {row['newton_iterations']} ({ns['status']}) {err}",
                      file=sys.stderr, flush=True)
    return rows


def fit(Ns, ys):
    pts = [(math.log(n), math.log(y)) for n, y in zip(Ns, ys) if y == y and y > 1e-14]
    if len(pts) < 2:
        return float("nan"), 0
    mx = sum(p[0] for p in pts) / len(pts)
    my = sum(p[1] for p in pts) / len(pts)
    return sum((x - mx) * (y - my) for x, y in pts) / sum((x - mx) ** 2 for x, _ in pts), len(pts)


def report_and_plot(rows, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = lambda r, k: float(r[k]) if r[k] not in ("", None) else float("nan")  # noqa: E731
    print("| order | N | Newton iterations (time) | 1 − ρ (pardel check) | 1 − ρ (assembled H) | 1 − ρ (last sweeps) | "
          "predicted sweeps to tol | Jacobi–Newton after cap |")
    print("|---|---|---|---|---|---|---|---|")
    fig, ax = plt.subplots(figsize=(7, 5))
    for order in sorted({int(r["order"]) for r in rows}):
        rs = [r for r in rows if int(r["order"]) == order]
        for r in rs:
            ns = f(r, "newton_seconds")
            newton = (f"{r['newton_iterations']} ({ns:.1e} s)" if r["newton_status"] == "converged"
                      else r["newton_status"].split(":")[0] + " (rc 2)")
            check = (f"{f(r, 'one_minus_rho_check'):.2e}" if int(r["check_resolved"])
                     else f"not resolved (round-off level {f(r, 'check_roundoff'):.1e})")
            print(f"| {order} | {r['N']} | {newton} | "
                  f"{check} | {f(r, 'one_minus_rho_eig'):.2e} | {1 - f(r, 'rho_hist'):.2e} | "
                  f"{f(r, 'predicted_sweeps'):.2e} | " + (f"{r['jn_sweeps']} sweeps: residual {f(r, 'r0'):.1e} → "
                  f"{f(r, 'jn_final_residual'):.1e} (tol {f(r, 'tol'):.1e})" if r["jn_sweeps"] != "" else "-") + " |")
        Ns = [int(r["N"]) for r in rs]
        for key, style, label in (("one_minus_rho_eig", "o-", "assembled H"), ("one_minus_rho_check", "s--", "pardel check"),
                                  ("rho_hist", "^:", "last sweeps")):
            ys = [1 - f(r, key) if key == "rho_hist" else f(r, key) for r in rs]
            if key == "one_minus_rho_check":  # only where pardel check resolves it
                ys = [y if int(r["check_resolved"]) else float("nan") for y, r in zip(ys, rs)]
            p, n = fit(Ns, ys)
            print(f"order {order}, 1 - rho from {label}: fitted power N^{p:.2f} over {n} points (values > 1e-14)")
            ax.loglog(Ns, [y if y > 0 else float("nan") for y in ys], style, ms=4,
                      label=f"order {order}, {label}: N^{p:.2f}")
    ax.set_xlabel("N (T = 5)")
    ax.set_ylabel("1 − ρ (Jacobi iteration matrix)")
    ax.set_title("Jacobi–Newton contraction, hermite_gauss(s = order)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    print(f"chart: {os.path.relpath(png, ROOT)}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"), help="folder with pardel and pardel-gen")
    ap.add_argument("--N", default=",".join(map(str, DEFAULT_N)), help="comma-separated grid sizes")
    ap.add_argument("--sweeps", type=int, default=20000, help="cap on the Jacobi-Newton sweeps")
    ap.add_argument("--reuse", action="store_true", help="table and chart from the existing CSV")
    args = ap.parse_args()
    csv_path = os.path.join(IMAGES, "jacobi_contraction.csv")
    png = os.path.join(IMAGES, "jacobi_contraction.png")
    if args.reuse:
        with open(csv_path) as f:
            rows = list(csv.DictReader(f))
    else:
        rows = measure(os.path.abspath(args.build), [int(n) for n in args.N.split(",")], args.sweeps)
        with open(csv_path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)
    report_and_plot(rows, png)


if __name__ == "__main__":
    main()

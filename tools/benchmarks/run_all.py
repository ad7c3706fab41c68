#!/usr/bin/python3
"""Runs pardel's benchmarks and writes their CSVs and PNG charts to docs/images/bench_*.

Usage (from the project root, after building with -DCMAKE_BUILD_TYPE=Release):
  /usr/bin/python3 tools/benchmarks/run_all.py --build build [--only peer,scaling,...] [--quick]

Parts: peer (fuel example, every method and IPOPT), sweep (Google Benchmark: sweep against
kernels alone, N and threads), scaling (time to solution against N and threads), memory (max RSS
per node at large N), workprec (work-precision per seed example), stability (heat maps).
Each part writes docs/images/bench_<part>*.csv and .png; machine.txt records the machine.
"""
import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "docs", "images")
COLORS = {"newton": "C0", "multigrid": "C1", "hybrid": "C2", "jacobi-newton": "C3", "jacobi": "C4",
          "ipopt": "C5", "newton-nested": "C6"}


REUSE = False  # --reuse: draw from the CSVs already in docs/images instead of measuring again


def run_csv(cmd, name):
    """Runs a command whose stdout is CSV, saves it as bench_<name>.csv, returns its rows."""
    path = os.path.join(OUT, f"bench_{name}.csv")
    if REUSE and os.path.exists(path):
        print("  reusing", os.path.relpath(path, ROOT), flush=True)
        return list(csv.DictReader(open(path)))
    print("$", " ".join(cmd), flush=True)
    start = time.time()
    load_before = os.getloadavg()[0]
    out = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True).stdout
    print(f"  ({time.time() - start:.1f} s)", flush=True)
    note_load(name, start, load_before)
    path = os.path.join(OUT, f"bench_{name}.csv")
    with open(path, "w") as f:
        f.write(out)
    return list(csv.DictReader(out.splitlines()))


def note_load(name, start, load_before):
    """Appends the machine's load around one measurement to bench_load.csv (the machine is shared)."""
    path = os.path.join(OUT, "bench_load.csv")
    new = not os.path.exists(path)
    with open(path, "a") as f:
        if new:
            f.write("part,start_utc,seconds,load1_before,load1_after\n")
        f.write(f"{name},{time.strftime('%Y-%m-%d %H:%M:%S', time.gmtime(start))},{time.time() - start:.1f},"
                f"{load_before:.2f},{os.getloadavg()[0]:.2f}\n")


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def save(fig, name):
    path = os.path.join(OUT, f"bench_{name}.png")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    print("  wrote", os.path.relpath(path, ROOT))


def machine(build):
    lines = [f"date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
             f"host: {platform.node()} {platform.machine()} {platform.system()} {platform.release()}"]
    try:
        cpu = subprocess.run(["lscpu"], stdout=subprocess.PIPE, text=True).stdout
        for line in cpu.splitlines():
            if line.split(":")[0].strip() in ("Model name", "CPU(s)", "Thread(s) per core", "L2 cache", "L3 cache"):
                lines.append(line.strip())
    except OSError:
        pass
    with open("/proc/meminfo") as f:
        lines.append(f.readline().strip())
    lines.append("load average at start: " + " ".join(f"{x:.2f}" for x in os.getloadavg()))
    cache = os.path.join(build, "CMakeCache.txt")
    if os.path.exists(cache):
        for line in open(cache):
            if line.startswith(("CMAKE_BUILD_TYPE:", "CMAKE_CXX_COMPILER:", "CMAKE_CXX_FLAGS_RELEASE:")):
                lines.append(line.strip())
    with open(os.path.join(OUT, "bench_machine.txt"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


def part_peer(suite, quick):
    Ns = "200,2000" if quick else "200,2000,20000,200000"
    cap = "5" if quick else "20"
    rows = run_csv([suite, "peer", "--N", Ns, "--cap", cap, "--threads", "1"], "peer")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    methods = [m for m in ["newton", "newton-nested", "multigrid", "hybrid", "jacobi-newton", "ipopt"]
               if any(r["method"] == m for r in rows)]
    Nvals = sorted({int(r["N"]) for r in rows})
    width = 0.8 / max(1, len(methods))
    for i, m in enumerate(methods):
        xs, ys, hatch = [], [], []
        for j, N in enumerate(Nvals):
            r = next((r for r in rows if r["method"] == m and int(r["N"]) == N), None)
            if r is None:
                continue
            t = num(r["seconds"])
            capped = r["status"] == "time_cap"
            extrapolated = num(r["extrapolated_seconds"])
            if capped and np.isfinite(extrapolated) and extrapolated > 0:
                t = extrapolated
            xs.append(j + (i - (len(methods) - 1) / 2) * width)
            ys.append(t)
            hatch.append(capped or r["status"] not in ("converged", "Solve_Succeeded"))
        bars = ax.bar(xs, ys, width, label=m, color=COLORS.get(m))
        for b, h in zip(bars, hatch):
            if h:
                b.set_hatch("//")
                b.set_alpha(0.6)
    ax.set_xticks(range(len(Nvals)), [f"N = {N:,}" for N in Nvals])
    ax.set_yscale("log")
    ax.set_ylabel("wall time to DEL residual 1e-10 [s]")
    ax.set_title("fuel_nav (T = 30, trapezoid): pardel methods vs IPOPT\n"
                 "hatched: not converged to 1e-10 (time cap: bar = extrapolated time, or the capped time; IPOPT: 'acceptable')",
                 fontsize=9)
    ax.legend(fontsize=8)
    save(fig, "peer")


def part_sweep(build, quick):
    exe = os.path.join(build, "pardel-bench-sweep")
    if not os.path.exists(exe):
        print("  pardel-bench-sweep not built; skipped")
        return
    js = os.path.join(OUT, "bench_sweep.json")
    filt = "BM_(SweepKernelsOnly|JacobiNewtonSweep)/(100|1000|10000)/" if quick else "."
    cmd = [exe, f"--benchmark_filter={filt}", f"--benchmark_out={js}", "--benchmark_out_format=json",
           "--benchmark_min_time=0.2"]
    if REUSE and os.path.exists(js):
        print("  reusing", os.path.relpath(js, ROOT), flush=True)
    else:
        print("$", " ".join(cmd), flush=True)
        subprocess.run(cmd, check=True)
    data = json.load(open(js))
    rows = []
    for b in data["benchmarks"]:
        name, N, th = b["name"].split("/")[:3]
        unit = {"us": 1e-6, "ms": 1e-3, "ns": 1e-9, "s": 1.0}[b["time_unit"]]
        rows.append({"benchmark": name.replace("BM_", ""), "N": int(N), "threads": int(th.split(":")[0]),
                     "seconds": b["real_time"] * unit, "iterations": b.get("iterations", ""),
                     "solver_iterations": b.get("iterations_", b.get("counters", {}).get("iterations", ""))})
    with open(os.path.join(OUT, "bench_sweep.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["benchmark", "N", "threads", "seconds", "node_updates_per_s",
                                          "sweep_over_kernels", "parallel_efficiency"])
        w.writeheader()
        lookup = {(r["benchmark"], r["N"], r["threads"]): r["seconds"] for r in rows}
        for r in rows:
            k = lookup.get(("SweepKernelsOnly", r["N"], r["threads"]))
            t1 = lookup.get((r["benchmark"], r["N"], 1))
            w.writerow({"benchmark": r["benchmark"], "N": r["N"], "threads": r["threads"],
                        "seconds": f"{r['seconds']:.6e}",
                        "node_updates_per_s": f"{(r['N'] - 1) / r['seconds']:.4e}"
                        if r["benchmark"] in ("SweepKernelsOnly", "JacobiNewtonSweep") else "",
                        "sweep_over_kernels": f"{r['seconds'] / k:.3f}" if k and r["benchmark"] == "JacobiNewtonSweep" else "",
                        "parallel_efficiency": f"{t1 / (r['threads'] * r['seconds']):.3f}" if t1 else ""})
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, style in [("SweepKernelsOnly", "--"), ("JacobiNewtonSweep", "-")]:
        for th in (1, 2):
            pts = sorted((r["N"], r["seconds"]) for r in rows if r["benchmark"] == name and r["threads"] == th)
            if pts:
                x, y = zip(*pts)
                axes[0].loglog(x, np.array(y) / np.array(x), style, marker="o", label=f"{name}, {th} thread(s)")
    axes[0].set_xlabel("N")
    axes[0].set_ylabel("seconds per node per sweep")
    axes[0].set_title("Jacobi-Newton sweep vs its kernels alone (fuel_nav)", fontsize=9)
    axes[0].legend(fontsize=7)
    for name in ("NewtonSolve",):
        for th in (1, 2):
            pts = sorted((r["N"], r["seconds"]) for r in rows if r["benchmark"] == name and r["threads"] == th)
            if pts:
                x, y = zip(*pts)
                axes[1].loglog(x, y, marker="o", label=f"{name}, {th} thread(s)")
    if any(r["benchmark"] == "NewtonSolve" for r in rows):
        axes[1].set_xlabel("N")
        axes[1].set_ylabel("time to residual 1e-10 [s]")
        axes[1].set_title("time to solution (fuel_nav)", fontsize=9)
        axes[1].legend(fontsize=7)
    else:
        fig.delaxes(axes[1])
    save(fig, "sweep")


def part_scaling(suite, quick, threads):
    Ns = "100,1000,10000" if quick else "100,1000,10000,100000,1000000,10000000"
    rows = run_csv([suite, "scaling", "--N", Ns, "--methods", "newton-nested", "--threads", threads,
                    "--cap", "60"], "scaling")
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for m in ("newton-nested", "newton", "multigrid", "hybrid"):
        for th in (1, 2):
            pts = sorted((int(r["N"]), num(r["seconds"])) for r in rows
                         if r["method"] == m and int(r["threads"]) == th and r["status"] == "converged")
            if pts:
                x, y = zip(*pts)
                ax.loglog(x, y, "-" if th == 2 else ":", marker="o", color=COLORS[m], label=f"{m}, {th} thread(s)")
    x = np.array([1e2, 1e7])
    ax.loglog(x, x * 1e-7, "k--", lw=0.8, label="slope 1 (linear in N)")
    ax.set_xlabel("N")
    ax.set_ylabel("time to DEL residual 1e-10 [s]")
    ax.set_title("fuel_nav: time to solution against N", fontsize=9)
    ax.legend(fontsize=7)
    save(fig, "scaling")


def part_memory(suite, quick):
    Ns = [1000, 100000] if quick else [1000, 1000000, 10000000]
    rows = []
    for method in ("jacobi-newton", "newton"):
        for N in Ns:
            out = subprocess.run([suite, "memory", "--N", str(N), "--method", method, "--iterations", "3"],
                                 check=True, stdout=subprocess.PIPE, text=True).stdout
            rows += list(csv.DictReader(out.splitlines()))
            print("  ", rows[-1], flush=True)
    with open(os.path.join(OUT, "bench_memory.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)


# The seed examples of the work-precision charts: scene, grid sizes, reference N (Richardson of the
# nested-Newton solutions at ref and ref/2; every N divides ref/2).
WORKPREC = [("scenes/fuel_nav.toml", "100,200,400,800,1600", "12800"),
            ("scenes/zermelo_1.toml", "20,40,80,160,320", "5120"),
            ("scenes/interp_fuel.toml", "60,120,240,480", "3840"),
            ("scenes/zermelo_tv.toml", "25,50,100,200", "1600"),
            ("scenes/spacecraft_fixed.toml", "25,50,100", "400")]


def part_workprec(suite, quick):
    examples = WORKPREC[:1] if quick else WORKPREC
    for scene, Ns, ref in examples:
        name = os.path.splitext(os.path.basename(scene))[0]
        rows = run_csv([suite, "workprec", "--scene", os.path.join(ROOT, scene), "--N", Ns, "--ref-N", ref,
                        "--cap", "2", "--threads", "1"], f"workprec_{name}")
        discs = sorted({r["discretization"] for r in rows})
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
        markers = ["o", "s", "^", "D"]
        for col, (ax, key, what) in enumerate(zip(axes, ("action_error", "max_error"),
                                                  ("|action - reference action|",
                                                   "max error of the coordinates at the nodes"))):
            for m in ("newton", "newton-nested", "hybrid", "jacobi-newton"):
                for di, d in enumerate(discs):
                    sel = sorted((num(r["seconds"]), num(r[key]), r["status"]) for r in rows
                                 if r["method"] == m and r["discretization"] == d)
                    ok = [(t, e) for t, e, st in sel if st == "converged" and np.isfinite(e)]
                    bad = [(t, e) for t, e, st in sel if st != "converged" and np.isfinite(e)]
                    style = "-" if di == 0 else "--"
                    if ok:
                        t, e = zip(*ok)
                        ax.loglog(t, np.maximum(e, 1e-16), style, marker=markers[di % 4], color=COLORS[m],
                                  label=f"{m}, {d}")
                    if bad:
                        t, e = zip(*bad)
                        ax.loglog(t, np.maximum(e, 1e-16), linestyle="none", marker=markers[di % 4], mfc="none",
                                  color=COLORS[m], label=f"{m}, {d}: not converged")
            ax.set_xlabel("wall time [s] (1 thread)")
            ax.set_ylabel(what)
        axes[0].set_title(f"{name}: work-precision, N = {Ns}; reference: Richardson extrapolation of N = {ref} "
                          f"and {int(ref) // 2}", fontsize=8)
        axes[1].set_title("hollow: not converged (2 s cap, or stalled)", fontsize=8)
        if any(a.get_legend_handles_labels()[0] for a in axes):
            axes[1].legend(fontsize=6, ncol=2)
        save(fig, f"workprec_{name}")


def part_stability(suite, quick):
    maps = [("harmonic", "omega h", "omega T"), ("bratu", "lambda", "N"), ("fuel", "damping epsilon", "N")]
    labels = ["reference solution", "other solution", "no convergence (cap)", "diverged / failed"]
    cmap = matplotlib.colors.ListedColormap(["#2ca02c", "#ff7f0e", "#bbbbbb", "#d62728"])
    for name, xl, yl in maps:
        cmd = [suite, "stability", "--map", name, "--cap", "1" if quick else "2"]
        rows = run_csv(cmd, f"stability_{name}")
        methods = [m for m in ("jacobi-newton", "newton", "multigrid", "hybrid") if any(r["method"] == m for r in rows)]
        fig, axes = plt.subplots(1, len(methods), figsize=(3.4 * len(methods), 3.6), squeeze=False)
        for ax, m in zip(axes[0], methods):
            rr = [r for r in rows if r["method"] == m]
            if name == "harmonic":
                xs = sorted({round(num(r["y"]), 4) for r in rr})  # omega T
                ys = sorted({int(r["N"]) for r in rr})
                grid = np.full((len(ys), len(xs)), np.nan)
                for r in rr:
                    grid[ys.index(int(r["N"])), xs.index(round(num(r["y"]), 4))] = int(r["outcome"])
                # Plot in (omega T, omega h) coordinates with scatter: omega h = omega T / N.
                pts = np.array([[num(r["y"]), num(r["x"]), int(r["outcome"])] for r in rr])
                ax.scatter(pts[:, 0], pts[:, 1], c=pts[:, 2], cmap=cmap, vmin=-0.5, vmax=3.5, marker="s", s=28)
                ax.set_yscale("log")
                ax.axvline(np.pi, color="k", lw=0.8, ls="--")
                ax.set_xlabel("omega T (dashed: first conjugate point pi)")
                ax.set_ylabel("omega h")
            else:
                xs = sorted({num(r["x"]) for r in rr})
                ys = sorted({int(r["y"]) for r in rr})
                grid = np.full((len(ys), len(xs)), np.nan)
                for r in rr:
                    grid[ys.index(int(r["y"])), xs.index(num(r["x"]))] = int(r["outcome"])
                ax.imshow(grid, origin="lower", aspect="auto", cmap=cmap, vmin=-0.5, vmax=3.5,
                          extent=[-0.5, len(xs) - 0.5, -0.5, len(ys) - 0.5], interpolation="nearest")
                step = max(1, len(xs) // 6)
                ax.set_xticks(range(0, len(xs), step), [f"{x:g}" for x in xs[::step]], fontsize=7)
                ax.set_yticks(range(len(ys)), [str(y) for y in ys])
                if name == "bratu":
                    ax.axvline(np.interp(3.5138, xs, range(len(xs))), color="k", lw=0.8, ls="--")
                ax.set_xlabel(xl)
                ax.set_ylabel(yl)
            ax.set_title(m, fontsize=9)
        handles = [matplotlib.patches.Patch(color=cmap(i), label=labels[i]) for i in range(4)]
        fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, bbox_to_anchor=(0.5, -0.08))
        fig.suptitle(f"stability map: {name}", fontsize=10)
        save(fig, f"stability_{name}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"), help="build folder with the benchmark programs")
    ap.add_argument("--only", default="peer,sweep,scaling,memory,workprec,stability", help="comma-separated parts")
    ap.add_argument("--quick", action="store_true", help="small sizes only (a smoke run, minutes)")
    ap.add_argument("--reuse", action="store_true", help="redraw charts from existing CSVs")
    ap.add_argument("--scaling-threads", default="1,2", help="thread counts of the scaling part")
    args = ap.parse_args()
    global REUSE
    REUSE = args.reuse
    build = os.path.abspath(args.build)
    suite = os.path.join(build, "pardel-bench-suite")
    if not os.path.exists(suite):
        sys.exit(f"run_all.py: error: {suite} not found; build the target pardel-bench-suite first")
    os.makedirs(OUT, exist_ok=True)
    if not REUSE:
        machine(build)
    parts = {"peer": lambda: part_peer(suite, args.quick), "sweep": lambda: part_sweep(build, args.quick),
             "scaling": lambda: part_scaling(suite, args.quick, args.scaling_threads), "memory": lambda: part_memory(suite, args.quick),
             "workprec": lambda: part_workprec(suite, args.quick),
             "stability": lambda: part_stability(suite, args.quick)}
    for p in args.only.split(","):
        if p not in parts:
            sys.exit(f"run_all.py: error: --only: unknown part '{p}' (have: {', '.join(parts)})")
        print(f"== {p}", flush=True)
        parts[p]()


if __name__ == "__main__":
    main()

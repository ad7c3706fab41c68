#!/usr/bin/python3
"""Robust-core benchmark: every problem solved with the solver's defaults, no tuning.

For each problem (the benchmark's own scenes in tools/benchmarks/scenes/, scenes/fuel_nav.toml,
and every other shipped scene scenes/*.toml) and each N, runs

    build/pardel solve SCENE --set grid.N=N --set solver.threads=1 --out DIR --quiet --no-plot

(no other setting: method and tolerance are the scene's, i.e. the solver's defaults for the
benchmark's scenes), reads DIR/summary.json and DIR/convergence.csv, and minimizes the same
discrete action at the same N with IPOPT (build/pardel-ipopt, one thread) where pardel-ipopt can
state the problem. Both run under a wall cap; the load average (/proc/loadavg) is recorded before
and after every measurement.

Usage (from the project root, Release build):
  /usr/bin/python3 tools/benchmarks/robust_core.py --build build
  /usr/bin/python3 tools/benchmarks/robust_core.py --build build --quick      # N <= 20,000, short caps
  /usr/bin/python3 tools/benchmarks/robust_core.py --build build --N 200,2000,20000,200000,2000000 \\
        --cap 300 --ipopt-cap 120 [--only rb_kepler,fuel_nav] [--no-ipopt]
  /usr/bin/python3 tools/benchmarks/robust_core.py --reuse                    # table and chart from the CSVs

Main problems (rb_kepler, rb_double_pendulum, rb_min_accel, fuel_nav) run at every N of --N;
the other shipped scenes at the first four (--shipped-N overrides). A scene with knots runs at
the nearest multiple of the N that puts every knot on a node (interp_fuel: multiples of 3, so
200 -> 201); the CSV keeps both N and N_requested. Writes
docs/images/bench_robust_runs.csv (one row per problem and N), bench_robust_levels.csv
(iterations per grid level), bench_robust_meta.csv (machine, commit, settings) and
bench_robust_time.png, and prints a markdown table.

IPOPT (pardel-ipopt) takes a bundled model's name or a .lag path, the discretization, params,
t0, T and the end points (for order 2 with their velocities), and always starts from the straight
line with uniform node times. Scenes with knots or with a clock mode (free_final_time,
fixed_total_time) are therefore left out of the IPOPT column (the reason is printed); scenes
with another guess (polyline) are run from the straight line and flagged, and the ratio is
flagged when the two actions differ (another local solution). IPOPT's tolerance (on the DEL
residual's infinity norm) is the scene's solver.tol when the scene sets one, else the threshold
pardel stopped against at that N (summary.json "tol" when positive, else the number after "<="
in its message, e.g. "DEL residual 5.6e-13 <= 2.1e-10 = max(rtol x scale ...)"), else
pardel-ipopt's default 1e-10; IPOPT's "acceptable" stop stays on. Each row records the scene
file's hash and the pardel program's hash and date (pardel_binary): by default the programs are
copied out of the build folder at the start (out/robust_core/bin), so a rebuild during the run
does not mix versions.
"""
import argparse
import csv
import glob
import hashlib
import json
import math
import os
import platform
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from fractions import Fraction

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HERE = os.path.join(ROOT, "tools", "benchmarks")
IMAGES = os.path.join(ROOT, "docs", "images")
MAIN_PROBLEMS = [
    ("rb_kepler", "tools/benchmarks/scenes/rb_kepler.toml"),
    ("rb_double_pendulum", "tools/benchmarks/scenes/rb_double_pendulum.toml"),
    ("rb_min_accel", "tools/benchmarks/scenes/rb_min_accel.toml"),
    ("fuel_nav", "scenes/fuel_nav.toml"),
]
DEFAULT_N = "200,2000,20000,200000,2000000"
QUICK_MAX_N = 20000
EXIT_NAMES = {0: "converged", 1: "internal_error", 2: "invalid_input", 3: "max_iterations", 4: "diverged",
              5: "non_finite", 6: "interrupted", 7: "stalled"}

RUN_FIELDS = [
    "problem", "scene", "scene_sha", "group", "N", "N_requested", "start_utc", "pardel_binary",
    "status", "exit_code", "capped", "message", "method", "iterations", "levels", "residual", "tol", "action",
    "point_kind", "point_source", "inertia", "lambda_min", "seconds", "elapsed_seconds",
    "load1_before", "load5_before", "load1_after", "load5_after",
    "ipopt_status", "ipopt_iterations", "ipopt_seconds", "ipopt_elapsed_seconds", "ipopt_residual",
    "ipopt_action", "ipopt_tol", "ipopt_note",
    "ipopt_load1_before", "ipopt_load5_before", "ipopt_load1_after", "ipopt_load5_after",
    "same_solution", "ratio",
]
LEVEL_FIELDS = ["problem", "N", "level", "level_N", "iterations", "residual_end", "action_end", "seconds_end"]


# ---------------------------------------------------------------------------------------------
# helpers

def loadavg():
    """(1-min, 5-min) load averages from /proc/loadavg."""
    try:
        with open("/proc/loadavg") as f:
            parts = f.read().split()
        return float(parts[0]), float(parts[1])
    except OSError:
        return float("nan"), float("nan")


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def fmt_g(x, digits=3):
    if isinstance(x, str) and x.startswith("<="):
        return "≤ " + fmt_g(x[2:], digits)
    x = num(x)
    if math.isnan(x):
        return "—"
    return f"{x:.{digits}g}"


def fmt_seconds(x):
    x = num(x)
    if math.isnan(x):
        return "—"
    if x < 1e-3:
        return f"{x * 1e6:.0f} µs"
    if x < 1:
        return f"{x * 1e3:.3g} ms"
    return f"{x:.3g} s"


def fmt_int(x):
    x = num(x)
    return "—" if math.isnan(x) else f"{int(x):,}"


def file_sha(path):
    """The first 12 hex digits of a file's SHA-256."""
    try:
        with open(path, "rb") as f:
            return hashlib.sha256(f.read()).hexdigest()[:12]
    except OSError:
        return "missing"


def binary_id(path):
    """Modification time and the first 12 hex digits of the SHA-256 of a program (the build
    folder may be rebuilt while the benchmark runs; rows measured with different programs are
    then told apart)."""
    try:
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
        mtime = time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(os.path.getmtime(path)))
        return f"{h.hexdigest()[:12]} {mtime}"
    except OSError:
        return "missing"


def snapshot_programs(build, dest, names):
    """Copies the programs out of the build folder, so that a rebuild during the benchmark does
    not mix versions: waits until each is at least 20 s old (not being linked), copies it, and
    checks that the copy runs."""
    os.makedirs(dest, exist_ok=True)
    for name in names:
        src = os.path.join(build, name)
        for _ in range(60):
            if os.path.exists(src) and time.time() - os.path.getmtime(src) > 20:
                break
            print(f"  waiting for {src} (being rebuilt)", flush=True)
            time.sleep(5)
        dst = os.path.join(dest, name)
        shutil.copy2(src, dst)
        if subprocess.run([dst, "--help"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode != 0:
            raise RuntimeError(f"the copy of {src} does not run")
    return dest


def shell_text(cmd):
    """A command as it would be typed in the project root."""
    return shlex.join(os.path.relpath(c, ROOT) if c.startswith(ROOT + os.sep) else c for c in cmd)


def parse_n_list(text):
    return [int(float(v)) for v in text.split(",") if v.strip()]


def run_capped(cmd, cap, env, graceful):
    """Runs cmd with a wall cap. graceful: SIGTERM at the cap (pardel then writes its outputs
    and exits 6), SIGKILL 30 s later; else SIGKILL at the cap. Returns (rc, stdout, stderr,
    elapsed, capped)."""
    start = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    capped = False
    try:
        out, err = proc.communicate(timeout=cap)
    except subprocess.TimeoutExpired:
        capped = True
        if graceful:
            proc.send_signal(signal.SIGTERM)
            try:
                out, err = proc.communicate(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                out, err = proc.communicate()
        else:
            proc.kill()
            out, err = proc.communicate()
    return proc.returncode, out, err, time.monotonic() - start, capped


# ---------------------------------------------------------------------------------------------
# problems

def shipped_scenes():
    paths = sorted(glob.glob(os.path.join(ROOT, "scenes", "*.toml")))
    return [(os.path.splitext(os.path.basename(p))[0], os.path.relpath(p, ROOT)) for p in paths]


def read_scene(rel):
    with open(os.path.join(ROOT, rel), "rb") as f:
        return tomllib.load(f)


def knot_multiple(scene):
    """The smallest m such that every knot lies on a node when N is a multiple of m (1 without
    knots): each knot's (t - t0)/T as a fraction p/q needs q | N."""
    grid = scene.get("grid", {})
    t0, T = float(grid.get("t0", 0)), float(grid.get("T", 1))
    m = 1
    for k in scene.get("knots", []):
        q = Fraction((float(k["t"]) - t0) / T).limit_denominator(10000).denominator
        m = m * q // math.gcd(m, q)
    return m


def grid_N(scene, N):
    """N itself, or the nearest multiple of the scene's knot multiple (so the knots are nodes)."""
    m = knot_multiple(scene)
    return N if N % m == 0 else max(m, m * round(N / m))


def looks_like_path(spec):
    return "/" in spec or spec.endswith(".lag")


def pardel_threshold(summary):
    """The DEL-residual threshold pardel stopped against, when it says: summary.json's "tol"
    when positive, else the number after "<=" in its message ("DEL residual 5.6e-13 <= 2.1e-10
    = max(rtol x scale ...)"). None when neither is there."""
    if not summary:
        return None, ""
    tol = num(summary.get("tol"))
    if tol > 0:
        return tol, "summary tol"
    m = re.search(r"<=\s*([0-9.]+(?:[eE][-+]?[0-9]+)?)", str(summary.get("message", "")))
    if m and num(m.group(1)) > 0:
        return num(m.group(1)), "pardel's threshold"
    return None, ""


def ipopt_command(build, rel, scene, N, summary=None):
    """The pardel-ipopt command for the scene at N, or (None, reason) when it cannot state it.
    IPOPT's tolerance: the scene's solver.tol, else the threshold pardel stopped against at this
    N (pardel_threshold), else pardel-ipopt's default 1e-10."""
    solver = scene.get("solver", {})
    if scene.get("knots"):
        return None, "no IPOPT: the scene has knots (pardel-ipopt has no knot option)", None
    clock = solver.get("clock", "none")
    if clock != "none":
        return None, f"no IPOPT: clock = {clock} (pardel-ipopt uses uniform node times only)", None
    model = scene["model"]
    if looks_like_path(model):
        model = os.path.normpath(os.path.join(os.path.dirname(os.path.join(ROOT, rel)), model))
    grid = scene.get("grid", {})
    b = scene.get("boundary", {})
    q0, qN = list(b.get("q0", [])), list(b.get("qN", []))
    for start_key, end_key in (("v0", "vN"), ("a0", "aN"), ("j0", "jN")):
        if start_key in b:
            q0 += list(b[start_key])
            qN += list(b[end_key])
    cmd = [os.path.join(build, "pardel-ipopt"), "--model", model, "--N", str(N), "--T", repr(float(grid["T"])),
           "--t0", repr(float(grid.get("t0", 0))), "--q0", ",".join(repr(float(v)) for v in q0),
           "--qN", ",".join(repr(float(v)) for v in qN), "--threads", "1", "--csv"]
    if "discretization" in scene:
        disc = scene["discretization"]
        if disc == "trapezoid" and "v0" in b:
            disc = "trapezoid(alpha=1)"  # the scene reader's alias for order 2
        cmd += ["--disc", disc]
    for name, value in scene.get("params", {}).items():
        cmd += ["--param", f"{name}={float(value)!r}"]
    tol, source = solver.get("tol"), "scene"
    if tol is None:
        tol, source = pardel_threshold(summary)
    if tol is None:
        tol, source = 1e-10, "default"
    else:
        cmd += ["--tol", repr(float(tol))]
    note = ""
    kind = scene.get("guess", {}).get("kind", "linear")
    if kind != "linear":
        note = f"IPOPT from the straight line (the scene's guess is {kind})"
    return cmd, note, f"{float(tol):.3g} ({source})"


# ---------------------------------------------------------------------------------------------
# reading pardel's outputs

def point_of(summary):
    """(kind, source, inertia text, lambda_min) from summary.json: its "point" object when
    present, else derived from the certificate's inertia."""
    point = summary.get("point")
    if isinstance(point, dict):
        inertia = point.get("inertia")
        if isinstance(inertia, dict):
            keys = sorted(inertia, key=lambda k: (0 if "pos" in k else 1 if "neg" in k else 2, k))
            inertia = "/".join(str(inertia[k]) for k in keys)
        elif isinstance(inertia, (list, tuple)):
            inertia = "/".join(str(v) for v in inertia)
        elif inertia is None:
            parts = [point.get(k) for k in ("inertia_positive", "inertia_negative", "inertia_zero")]
            inertia = "/".join(str(v) for v in parts) if any(v is not None for v in parts) else ""
        lam = point.get("lambda_min", "")
        if point.get("lambda_settled") is False and point.get("kind") == "minimum":
            lam = f"<={lam}"  # an upper bound: the Lanczos iteration had not settled
        return str(point.get("kind", "")), "point", str(inertia), lam
    cert = summary.get("certificate")
    if isinstance(cert, dict) and "inertia_negative" in cert:
        pos, neg, zero = cert.get("inertia_positive"), cert.get("inertia_negative"), cert.get("inertia_zero")
        if neg:
            kind = "saddle"
        elif zero:
            kind = "degenerate"
        elif cert.get("hessian_positive_definite"):
            kind = "minimum"
        else:
            kind = "unknown"
        return kind, "certificate", f"{pos}/{neg}/{zero}", ""
    return "", "", "", ""


def levels_of(conv_path, total_iterations):
    """Per-level iteration counts from convergence.csv (columns iteration, N, residual, action,
    seconds; the iteration counter runs over all levels). Returns a list of dicts."""
    if not os.path.exists(conv_path):
        return []
    with open(conv_path) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return []
    have_n = "N" in rows[0]
    levels = []
    for r in rows:
        n = r.get("N", "") if have_n else ""
        it = int(float(r.get("iteration", 0) or 0))
        if not levels or levels[-1]["level_N"] != n:
            levels.append({"level_N": n, "first": it, "last": it, "row": r})
        else:
            levels[-1]["last"] = it
            levels[-1]["row"] = r
    # A record holds the state after iteration `iteration`, done on the grid N; the first record
    # (iteration 0) is the initial guess; a level reached already converged has one record with
    # the previous level's iteration number. So a level's count is its last iteration minus the
    # previous level's last (exact when every iteration is recorded, as Newton's history is).
    out = []
    previous = levels[0]["first"]
    for i, lv in enumerate(levels):
        last = lv["last"] if i + 1 < len(levels) else max(lv["last"], int(total_iterations or 0))
        count = last - previous
        previous = last
        out.append({"level": i, "level_N": lv["level_N"], "iterations": count,
                    "residual_end": lv["row"].get("residual", ""), "action_end": lv["row"].get("action", ""),
                    "seconds_end": lv["row"].get("seconds", "")})
    return out


def measure(args, problem, rel, group, N_requested, env):
    """One pardel run and one IPOPT run. Returns (run row, level rows)."""
    scene = read_scene(rel)
    N = grid_N(scene, N_requested)
    out_dir = os.path.join(args.work, f"{problem}_N{N}")
    shutil.rmtree(out_dir, ignore_errors=True)
    os.makedirs(out_dir)
    cmd = [os.path.join(args.build, "pardel"), "solve", rel, "--set", f"grid.N={N}", "--set", "solver.threads=1",
           "--out", out_dir, "--quiet", "--no-plot"]
    row = {k: "" for k in RUN_FIELDS}
    row.update(problem=problem, scene=rel, group=group, N=N, N_requested=N_requested,
               start_utc=time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()),
               pardel_binary=binary_id(os.path.join(args.build, "pardel")),
               scene_sha=file_sha(os.path.join(ROOT, rel)))
    if N != N_requested:
        print(f"  N = {N_requested:,} -> {N:,}: a multiple of {knot_multiple(scene)}, so that the knots are nodes")
    print("$ " + shell_text(cmd), flush=True)
    row["load1_before"], row["load5_before"] = loadavg()
    rc, out, err, elapsed, capped = run_capped(cmd, args.cap, env, graceful=True)
    row["load1_after"], row["load5_after"] = loadavg()
    row.update(exit_code=rc, capped=int(capped), elapsed_seconds=f"{elapsed:.3f}")
    summary_path = os.path.join(out_dir, "summary.json")
    levels = []
    summary = None
    if os.path.exists(summary_path):
        with open(summary_path) as f:
            summary = json.load(f)
        row.update(status=summary.get("status", EXIT_NAMES.get(rc, rc)), message=summary.get("message", ""),
                   method=summary.get("method", ""), iterations=summary.get("iterations", ""),
                   residual=summary.get("residual", ""), tol=summary.get("tol", ""),
                   action=summary.get("action", ""), seconds=summary.get("wall_seconds", ""))
        kind, source, inertia, lam = point_of(summary)
        row.update(point_kind=kind, point_source=source, inertia=inertia, lambda_min=lam)
        levels = levels_of(os.path.join(out_dir, "convergence.csv"), summary.get("iterations", 0))
    else:
        row.update(status=EXIT_NAMES.get(rc, f"exit {rc}") if rc is not None else "killed",
                   message=(err.strip().splitlines() or [""])[-1][:300])
    if capped:
        row["status"] = "cap"
        if not row["seconds"]:
            row["seconds"] = f"{elapsed:.3f}"
    row["levels"] = " ".join(f"{lv['level_N']}:{lv['iterations']}" for lv in levels)
    if not args.keep_outputs:
        for name in ("trajectory.csv", "checkpoint.json"):
            p = os.path.join(out_dir, name)
            if os.path.exists(p):
                os.remove(p)
    print(f"  pardel: {row['status']} (exit {rc}), {fmt_int(row['iterations'])} iterations, "
          f"{fmt_seconds(row['seconds'])}, residual {fmt_g(row['residual'])}, action {row['action']}, "
          f"point {row['point_kind'] or '—'}", flush=True)

    # IPOPT
    if args.no_ipopt:
        row["ipopt_status"] = "not run"
        row["ipopt_note"] = "--no-ipopt"
    else:
        icmd, note, itol = ipopt_command(args.build, rel, scene, N, summary)
        row["ipopt_note"] = note
        if icmd is None:
            row["ipopt_status"] = "n/a"
            print(f"  {note}", flush=True)
        else:
            row["ipopt_tol"] = itol
            print("$ " + shell_text(icmd), flush=True)
            row["ipopt_load1_before"], row["ipopt_load5_before"] = loadavg()
            irc, iout, ierr, ielapsed, icapped = run_capped(icmd, args.ipopt_cap, env, graceful=False)
            row["ipopt_load1_after"], row["ipopt_load5_after"] = loadavg()
            row["ipopt_elapsed_seconds"] = f"{ielapsed:.3f}"
            line = [ln for ln in iout.strip().splitlines() if ln.count(",") >= 6]
            if icapped:
                row.update(ipopt_status="cap", ipopt_seconds=f"{ielapsed:.3f}")
            elif line:
                f = line[-1].split(",")
                row.update(ipopt_status=f[2], ipopt_iterations=f[3], ipopt_seconds=f[4], ipopt_residual=f[5],
                           ipopt_action=f[6])
            else:
                row["ipopt_status"] = f"error (exit {irc})"
                msg = (ierr.strip().splitlines() or [""])[0][:300]
                row["ipopt_note"] = (note + "; " if note else "") + msg
            a, ia = num(row["action"]), num(row["ipopt_action"])
            if not (math.isnan(a) or math.isnan(ia)):
                row["same_solution"] = int(abs(a - ia) <= 1e-6 * max(1.0, abs(a)))
            ps, ips = num(row["seconds"]), num(row["ipopt_seconds"])
            if ps > 0 and not math.isnan(ips):
                row["ratio"] = f"{ips / ps:.4g}"
            print(f"  IPOPT: {row['ipopt_status']}, {fmt_int(row['ipopt_iterations'])} iterations, "
                  f"{fmt_seconds(row['ipopt_seconds'])}, residual {fmt_g(row['ipopt_residual'])}, "
                  f"action {row['ipopt_action'] or '—'}" + (f" [{note}]" if note else ""), flush=True)
    level_rows = [dict(problem=problem, N=N, **lv) for lv in levels]
    return row, level_rows


# ---------------------------------------------------------------------------------------------
# outputs

def write_csv(path, fields, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)


def markdown_table(rows):
    lines = ["| problem | N | status | method | point | λ_min | iterations (all levels) | per level (N:its) "
             "| seconds | IPOPT seconds | IPOPT status | IPOPT / pardel |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    notes = {}
    at_iterate = False
    for r in rows:
        status = r["status"]
        if str(r.get("capped")) == "1":
            status = "cap"
        ratio = r.get("ratio", "")
        ratio_text = "—"
        if ratio:
            ratio_text = f"{num(ratio):.3g}×"
            if r.get("ipopt_status") == "cap":
                ratio_text = "≥ " + ratio_text
            if status not in ("converged", "stalled"):
                ratio_text += " (pardel not converged)"
            elif str(r.get("same_solution")) == "0":
                ratio_text += " (other solution)"
        ist = r.get("ipopt_status") or "—"
        note = r.get("ipopt_note", "")
        if note:
            key = notes.setdefault(note, len(notes) + 1)
            ist += f" [{key}]"
        levels = r.get("levels", "")
        if levels and " " not in levels.strip():
            levels = "one level"
        kind = r.get("point_kind") or "—"
        if kind != "—" and status not in ("converged", "stalled"):
            kind = f"({kind})"
            at_iterate = True
        lines.append(f"| {r['problem']} | {int(num(r['N'])):,} | {status} | {r.get('method') or '—'} | "
                     f"{kind} | {fmt_g(r.get('lambda_min'))} | {fmt_int(r.get('iterations'))} | "
                     f"{levels or '—'} | {fmt_seconds(r.get('seconds'))} | {fmt_seconds(r.get('ipopt_seconds'))} | "
                     f"{ist} | {ratio_text} |")
    if notes or at_iterate:
        lines.append("")
    if at_iterate:
        lines.append("Point kind in parentheses: at the last iterate of a run that did not converge, not at a solution.")
    for note, key in notes.items():
        lines.append(f"[{key}] {note}")
    return "\n".join(lines)


def chart(rows, path, caps):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    problems = []
    for r in rows:
        if r["problem"] not in problems:
            problems.append(r["problem"])
    if not problems:
        return
    from matplotlib.ticker import NullFormatter
    ns = [num(r["N"]) for r in rows if num(r["N"]) > 0]
    xlim = (min(ns) / 1.6, max(ns) * 1.6)
    ncols = 4 if len(problems) > 6 else min(3, len(problems))
    nrows = math.ceil(len(problems) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.6 * ncols, 2.9 * nrows), squeeze=False)
    for ax in axes.flat[len(problems):]:
        ax.axis("off")
    for ax, p in zip(axes.flat, problems):
        rs = sorted((r for r in rows if r["problem"] == p), key=lambda r: num(r["N"]))
        for who, key, status_key, color, marker in (("pardel", "seconds", "status", "C0", "o"),
                                                    ("IPOPT", "ipopt_seconds", "ipopt_status", "C3", "s")):
            pts = [(num(r["N"]), num(r[key]), r[status_key], str(r.get("same_solution")) == "0")
                   for r in rs if num(r[key]) > 0]
            if not pts:
                continue
            ax.plot([x for x, _, _, _ in pts], [y for _, y, _, _ in pts], "-", color=color, lw=1, label=who)
            for x, y, st, other in pts:
                ok = st in ("converged", "stalled", "Solve_Succeeded", "Solved_To_Acceptable_Level")
                m = "^" if st == "cap" else "x" if (other and who == "IPOPT") else marker
                ax.plot([x], [y], m, color=color, mfc=color if ok else "white", ms=5)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(xlim)
        ys = [num(r[k]) for r in rs for k in ("seconds", "ipopt_seconds") if num(r[k]) > 0]
        if ys:
            lo, hi = min(ys), max(ys)
            if hi / lo < 100:  # at least two decades, so that every panel reads the same way
                mid = math.sqrt(lo * hi)
                lo, hi = min(lo, mid / 10), max(hi, mid * 10)
            ax.set_ylim(lo / 1.5, hi * 1.5)
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(p, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="major", lw=0.3)
    axes.flat[0].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("N", fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel("seconds", fontsize=8)
    fig.suptitle("Time to solution against N, one thread. Filled: pardel converged (or stalled at round-off), "
                 "IPOPT Solve_Succeeded or Solved_To_Acceptable_Level;\n"
                 f"hollow: not converged; triangle: stopped by the wall cap ({caps}); "
                 "x: IPOPT ended on another solution (action differs)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def meta_rows(args, n_main, n_shipped):
    rows = [("date_utc", time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime())),
            ("host", platform.node()), ("machine", platform.machine()), ("cores", os.cpu_count())]
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    rows.append(("cpu", line.split(":", 1)[1].strip()))
                    break
    except OSError:
        pass
    try:
        with open("/proc/meminfo") as f:
            rows.append(("memory", f.readline().split(":", 1)[1].strip()))
    except OSError:
        pass
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout.strip()
        rows.append(("commit", commit + (" (with uncommitted changes)" if dirty else "")))
    except OSError:
        pass
    cache = os.path.join(args.build_folder, "CMakeCache.txt")
    if os.path.exists(cache):
        for line in open(cache):
            if line.startswith(("CMAKE_BUILD_TYPE:", "CMAKE_CXX_COMPILER:")):
                k, v = line.strip().split("=", 1)
                rows.append((k.split(":")[0], v))
    rows += [("pardel", binary_id(os.path.join(args.build, "pardel"))),
             ("pardel-ipopt", binary_id(os.path.join(args.build, "pardel-ipopt"))),
             ("build", os.path.relpath(args.build_folder, ROOT)),
             ("programs_run", os.path.relpath(args.build, ROOT)), ("N_main", " ".join(map(str, n_main))),
             ("N_shipped", " ".join(map(str, n_shipped))), ("pardel_cap_seconds", args.cap),
             ("ipopt_cap_seconds", args.ipopt_cap), ("quick", int(args.quick)),
             ("load_at_start", " ".join(open("/proc/loadavg").read().split()[:3]))]
    return [{"key": k, "value": v} for k, v in rows]


# ---------------------------------------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build", help="build folder with pardel and pardel-ipopt")
    ap.add_argument("--quick", action="store_true",
                    help=f"N <= {QUICK_MAX_N:,} only; caps 5 s (pardel) and 5 s (IPOPT) unless given")
    ap.add_argument("--N", default=None, help=f"comma-separated N for the main problems (default {DEFAULT_N})")
    ap.add_argument("--shipped-N", default=None, help="N for the other shipped scenes (default: the first four of --N)")
    ap.add_argument("--cap", type=float, default=None, help="wall cap per pardel run, seconds (default 300)")
    ap.add_argument("--ipopt-cap", type=float, default=None, help="wall cap per IPOPT run, seconds (default 120)")
    ap.add_argument("--only", default="", help="comma-separated problem names (scene stems)")
    ap.add_argument("--no-ipopt", action="store_true", help="leave IPOPT out")
    ap.add_argument("--no-shipped", action="store_true", help="only the main problems")
    ap.add_argument("--work", default=os.path.join(ROOT, "out", "robust_core"),
                    help="folder for the runs' outputs (default out/robust_core)")
    ap.add_argument("--keep-outputs", action="store_true", help="keep trajectory.csv of every run")
    ap.add_argument("--images", default=IMAGES, help="where the CSVs and the chart go (default docs/images)")
    ap.add_argument("--reuse", action="store_true", help="print the table and draw the chart from the CSVs only")
    ap.add_argument("--no-snapshot", action="store_true",
                    help="run the programs in the build folder itself (default: copies in WORK/bin, taken at the start)")
    args = ap.parse_args()
    args.build = os.path.abspath(os.path.join(ROOT, args.build))
    args.work = os.path.abspath(args.work)
    runs_csv = os.path.join(args.images, "bench_robust_runs.csv")
    levels_csv = os.path.join(args.images, "bench_robust_levels.csv")
    meta_csv = os.path.join(args.images, "bench_robust_meta.csv")
    png = os.path.join(args.images, "bench_robust_time.png")

    if args.reuse:
        with open(runs_csv) as f:
            rows = list(csv.DictReader(f))
        caps = ""
        if os.path.exists(meta_csv):
            meta = {r["key"]: r["value"] for r in csv.DictReader(open(meta_csv))}
            caps = f"pardel {meta.get('pardel_cap_seconds', '?')} s, IPOPT {meta.get('ipopt_cap_seconds', '?')} s"
        chart(rows, png, caps)
        print(markdown_table(rows))
        return 0

    n_main = parse_n_list(args.N or DEFAULT_N)
    if args.quick:
        n_main = [n for n in n_main if n <= QUICK_MAX_N]
    n_shipped = parse_n_list(args.shipped_N) if args.shipped_N else n_main[:4]
    if args.cap is None:
        args.cap = 5.0 if args.quick else 300.0
    if args.ipopt_cap is None:
        args.ipopt_cap = 5.0 if args.quick else 120.0
    for exe in ("pardel", "pardel-ipopt"):
        if not os.access(os.path.join(args.build, exe), os.X_OK) and not (exe == "pardel-ipopt" and args.no_ipopt):
            print(f"robust_core.py: {os.path.join(args.build, exe)} not found (build it first)", file=sys.stderr)
            return 2

    main_names = {name for name, _ in MAIN_PROBLEMS}
    problems = [(name, rel, "benchmark" if name.startswith("rb_") else "shipped", n_main) for name, rel in MAIN_PROBLEMS]
    if not args.no_shipped:
        problems += [(name, rel, "shipped", n_shipped) for name, rel in shipped_scenes() if name not in main_names]
    only = [p for p in args.only.split(",") if p]
    if only:
        unknown = set(only) - {p[0] for p in problems}
        if unknown:
            print(f"robust_core.py: unknown problem(s): {', '.join(sorted(unknown))}", file=sys.stderr)
            return 2
        problems = [p for p in problems if p[0] in only]

    os.makedirs(args.work, exist_ok=True)
    os.makedirs(args.images, exist_ok=True)
    args.build_folder = args.build
    if not args.no_snapshot:
        args.build = snapshot_programs(args.build, os.path.join(args.work, "bin"),
                                       ["pardel"] + ([] if args.no_ipopt else ["pardel-ipopt"]))
    env = dict(os.environ, OMP_NUM_THREADS="1")
    meta = meta_rows(args, n_main, n_shipped)
    for m in meta:
        print(f"# {m['key']}: {m['value']}")
    rows, level_rows = [], []
    for name, rel, group, ns in problems:
        for N in ns:
            row, lv = measure(args, name, rel, group, N, env)
            rows.append(row)
            level_rows += lv
            # written after every run, so that an interrupted benchmark keeps what it measured
            write_csv(runs_csv, RUN_FIELDS, rows)
            write_csv(levels_csv, LEVEL_FIELDS, level_rows)
    meta.append({"key": "load_at_end", "value": " ".join(open("/proc/loadavg").read().split()[:3])})
    binaries = sorted({r["pardel_binary"] for r in rows})
    if len(binaries) > 1:
        warning = f"build/pardel changed during the run ({len(binaries)} versions: {'; '.join(binaries)})"
        meta.append({"key": "warning", "value": warning})
        print(f"WARNING: {warning}; the column pardel_binary of bench_robust_runs.csv tells the rows apart",
              file=sys.stderr)
    write_csv(meta_csv, ["key", "value"], meta)
    chart(rows, png, f"pardel {args.cap:g} s, IPOPT {args.ipopt_cap:g} s")
    print()
    print(markdown_table(rows))
    print()
    for p in (runs_csv, levels_csv, meta_csv, png):
        print("wrote", os.path.relpath(p, ROOT))
    return 0


if __name__ == "__main__":
    sys.exit(main())

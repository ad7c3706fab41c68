#!/usr/bin/python3
"""Regenerates the table that compares pardel-gen's kernels with the SymPy peer (docs/codegen.md).

For every bundled model (or those named) and each of its discretizations:
  1. pardel-gen + render.py emit pardel's kernels (the `full` kernel is compared);
  2. sympy_ccode.py emits the SymPy peer (sympy.diff, sympy.cse, C99CodePrinter) and records
     SymPy's own operation count before and after cse;
  3. count_ops.py counts both emitted functions with the same counter;
  4. peer_bench.cpp times both on one core over the same random inputs; everything is compiled
     with the same compiler and flags (FLAGS below; no -ffast-math).
Writes OUT/table.md, OUT/results.json and prints the table.

Usage:
  /usr/bin/python3 tools/codegen_peer/run_peer.py --pardel-gen build-models/pardel-gen \
      [--out out/codegen_peer] [--model NAME ...] [--reuse-sympy] [--seconds 0.2] [--rounds 5]
"""

import argparse
import glob
import json
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import check_kernels  # noqa: E402
import count_ops  # noqa: E402
import sympy_kernels  # noqa: E402

ROOT = sympy_kernels.PROJECT_ROOT
FLAGS = ["-O3", "-march=native"]
CXX = os.environ.get("CXX", "g++")
CC = os.environ.get("CC", "gcc")


def sanitize(disc):
    return re.sub(r"[^A-Za-z0-9]+", "_", disc).strip("_")


def run(cmd, **kw):
    proc = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if proc.returncode != 0:
        sys.exit("error: `%s` failed (%d):\n%s%s" % (" ".join(cmd), proc.returncode, proc.stdout, proc.stderr))
    return proc.stdout


def pardel_full_function(source, disc):
    """The name of the full kernel of `disc` in the model's discretization table."""
    m = re.search(r'\{"%s",\s*\d+,\s*([A-Za-z_][A-Za-z0-9_]*)' % re.escape(disc), source)
    if not m:
        sys.exit("error: discretization %s not found in the generated source" % disc)
    return m.group(1)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--pardel-gen", required=True)
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "codegen_peer"))
    parser.add_argument("--model", action="append", default=[])
    parser.add_argument("--reuse-sympy", action="store_true", help="keep peer C files already in OUT")
    parser.add_argument("--seconds", default="0.2", help="minimum seconds per timed round")
    parser.add_argument("--rounds", default="5")
    args = parser.parse_args(argv)
    out = os.path.abspath(args.out)
    for sub in ("pardel", "sympy", "bin"):
        os.makedirs(os.path.join(out, sub), exist_ok=True)
    names = args.model or sorted(os.path.basename(p)[:-4] for p in glob.glob(os.path.join(ROOT, "lagrangians", "*.lag")))

    rows, entries, sources = [], [], []
    for name in names:
        lag = os.path.join(ROOT, "lagrangians", name + ".lag")
        model = sympy_kernels.parse_lag(lag)
        ir = os.path.join(out, "pardel", name + ".ir.json")
        run([args.pardel_gen, lag, "-o", ir, "--source-name", "lagrangians/%s.lag" % name])
        run(["/usr/bin/python3", os.path.join(ROOT, "codegen", "render.py"), ir, "--out-dir", os.path.join(out, "pardel")])
        pardel_cpp = os.path.join(out, "pardel", name + ".cpp")
        with open(pardel_cpp) as f:
            pardel_source = f.read()
        sources.append(pardel_cpp)
        for disc in model.discretizations:
            fn = "peer_%s_%s" % (name, sanitize(disc))
            peer_c = os.path.join(out, "sympy", fn + ".c")
            stats_file = os.path.join(out, "sympy", fn + ".json")
            if not (args.reuse_sympy and os.path.exists(peer_c) and os.path.exists(stats_file)):
                started = time.time()
                run(["/usr/bin/python3", os.path.join(HERE, "sympy_ccode.py"), "--model", lag, "--disc", disc,
                     "--function", fn, "--out", peer_c, "--stats", stats_file])
                print("sympy peer %-16s %-20s %.0f s" % (name, disc, time.time() - started), file=sys.stderr)
            with open(stats_file) as f:
                stats = json.load(f)
            peer_div, pardel_div = {}, {}
            with open(peer_c) as f:
                peer_ops = count_ops.count_function(f.read(), fn, peer_div)
            ours = pardel_full_function(pardel_source, disc)
            pardel_ops = count_ops.count_function(pardel_source, ours, pardel_div)
            sources.append(peer_c)
            spec = check_kernels._sampling(model)
            entries.append((name, disc, fn, len(model.coords), model.order * len(model.coords), spec))
            rows.append({"model": name, "disc": disc, "sympy_ops_before_cse": stats["sympy_ops_before_cse"],
                         "sympy_ops_after_cse": stats["sympy_ops_after_cse"], "peer_c_ops": peer_ops,
                         "pardel_c_ops": pardel_ops, "peer_c_divisions": peer_div.get("div", 0),
                         "pardel_c_divisions": pardel_div.get("div", 0)})

    # The registry and the driver, compiled with the same flags as both kernels' sources.
    registry = os.path.join(out, "bin", "peer_registry.cpp")
    with open(registry, "w") as f:
        f.write("// Written by run_peer.py: the kernels peer_bench compares.\n#include \"peer_bench.hpp\"\n\n")
        for name in sorted({e[0] for e in entries}):
            f.write('extern "C" const pardel_model %s_model;\n' % name)
        f.write('extern "C" {\n')
        for e in entries:
            f.write("void %s(double, double, double, const double*, const double*, const double*, double*, double*,"
                    " double*, double*, double*, double*);\n" % e[2])
        f.write("}\n\nconst PeerEntry kPeerEntries[] = {\n")
        for name, disc, fn, ncoords, dim, s in entries:
            f.write('    {&%s_model, "%s", %s, %d, %d, %r, %r, %r, %r, %r, %r, %r, %r},\n'
                    % (name, disc, fn, ncoords, dim, *s["coords"], *s["derivs"], *s["h"], *s["t0"]))
        f.write("};\nconst int kPeerEntryCount = %d;\n" % len(entries))
    objects = []
    include = ["-I", os.path.join(ROOT, "runtime", "include"), "-I", HERE, "-I", os.path.join(out, "pardel")]
    for src in sources + [registry, os.path.join(HERE, "peer_bench.cpp")]:
        obj = os.path.join(out, "bin", os.path.basename(src) + ".o")
        if src.endswith(".c"):
            run([CC, "-std=c99", *FLAGS, "-c", src, "-o", obj])
        else:
            run([CXX, "-std=c++17", *FLAGS, *include, "-c", src, "-o", obj])
        objects.append(obj)
    bench = os.path.join(out, "bin", "peer_bench")
    run([CXX, *FLAGS, *objects, "-o", bench, "-lm"])
    timings = {}
    for line in run([bench, args.seconds, args.rounds]).splitlines():
        r = json.loads(line)
        timings[(r["model"], r["disc"])] = r
    for row in rows:
        r = timings[(row["model"], row["disc"])]
        row.update(pardel_evals_per_s=r["pardel_evals_per_s"], peer_evals_per_s=r["peer_evals_per_s"],
                   max_rel_diff=r["max_rel_diff"])

    lines = ["| model | discretization | SymPy count_ops before → after cse | peer C ops (div) | pardel C ops (div) "
             "| peer evals/s | pardel evals/s | pardel/peer speed | max rel diff |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append("| %s | %s | %d → %d | %d (%d) | %d (%d) | %.3g | %.3g | %.2f | %.1e |"
                     % (r["model"], r["disc"], r["sympy_ops_before_cse"], r["sympy_ops_after_cse"], r["peer_c_ops"],
                        r["peer_c_divisions"], r["pardel_c_ops"], r["pardel_c_divisions"], r["peer_evals_per_s"],
                        r["pardel_evals_per_s"], r["pardel_evals_per_s"] / r["peer_evals_per_s"], r["max_rel_diff"]))
    table = "\n".join(lines) + "\n"
    with open(os.path.join(out, "table.md"), "w") as f:
        f.write(table)
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump({"flags": [CXX] + FLAGS, "rows": rows}, f, indent=1)
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())

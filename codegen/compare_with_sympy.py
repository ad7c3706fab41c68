#!/usr/bin/python3
"""Compares the operation counts of pardel-gen's `full` kernels with SymPy's cse + C printing of
the same discrete Lagrangian and derivatives (tools/codegen_peer/sympy_ccode.py).

Both sides are counted on the emitted C text with pardel-gen's convention: each binary + - * /,
each unary minus and each function call (pow included) is one operation; copies of symmetric
entries are free. Prints one row per model and discretization; exit status 1 when pardel-gen
needs more operations than SymPy anywhere.

usage: /usr/bin/python3 codegen/compare_with_sympy.py --pardel-gen build/pardel-gen [--timeout S] LAG...
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PEER = os.path.join(ROOT, "tools", "codegen_peer", "sympy_ccode.py")
TOKEN = re.compile(r"\s*(?:(\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?)|([A-Za-z_][A-Za-z0-9_:]*)|(.))")


CONSTANT_GROUP = re.compile(r"(?<![A-Za-z0-9_])\(\s*[-+]?[\d.]+(?:[eE][-+]?\d+)?(?:\s*[-+*/]\s*[\d.]+(?:[eE][-+]?\d+)?)*\s*\)")


def fold_constants(expr):
    """Replaces parenthesized groups of literals, such as SymPy's (1.0/2.0) or pardel's (-0.5),
    by one literal: the compiler folds them, so they cost nothing at run time."""
    while True:
        folded = CONSTANT_GROUP.sub("1.0", expr)
        if folded == expr:
            return expr
        expr = folded


def count_ops(expr):
    """Operations in one C expression: binary + - * /, unary minus, calls."""
    ops = 0
    prev = None  # kind of the previous token: 'value', 'op', '(' or None
    tokens = TOKEN.findall(fold_constants(expr))
    for index, (number, name, char) in enumerate(tokens):
        if number:
            prev = "value"
        elif char == "-" and prev in (None, "op", "(") and index + 1 < len(tokens) and tokens[index + 1][0]:
            prev = "op"  # a negative literal such as -2 in -2*x: no operation
        elif name:
            prev = "name"
        elif char in "+-":
            ops += 1  # binary, or unary minus; a unary plus does not occur in either printer
            if char == "+" and prev in (None, "op", "("):
                ops -= 1
            prev = "op"
        elif char in "*/":
            ops += 1
            prev = "op"
        elif char == "(":
            if prev == "name":
                ops += 1  # a function call
            prev = "("
        elif char == ")":
            prev = "value"
        elif char == ",":
            prev = "op"
        elif char in "[]":
            prev = "value" if char == "]" else "("
    return ops


def ops_of_c_function(text):
    total = 0
    for line in text.splitlines():
        m = re.match(r"\s*(?:const double\s+)?([A-Za-z_][A-Za-z0-9_]*(?:\[\d+\])?)\s*=\s*(.*);\s*$", line)
        if not m:
            continue
        rhs = m.group(2)
        # Index expressions such as q0[3] contain no operations; strip them first.
        rhs = re.sub(r"\[\d+\]", "", rhs)
        total += count_ops(rhs)
    return total


def pardel_counts(gen, lag, workdir):
    ir_path = os.path.join(workdir, "ir.json")
    subprocess.run([gen, lag, "-o", ir_path], check=True)
    with open(ir_path) as f:
        ir = json.load(f)
    out = {}
    for disc in ir["discretizations"]:
        for k in disc["kernels"]:
            if k["variant"] == "full":
                text = "\n".join("const double %s = %s;" % (t["name"], t["expr"]) for t in k["temporaries"])
                text += "\n" + "\n".join("%s = %s;" % (o["target"], o["expr"]) for o in k["outputs"])
                out[disc["name"]] = (ops_of_c_function(text), k["ops_after_cse"])
    return out


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--pardel-gen", required=True)
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds allowed to SymPy per kernel")
    parser.add_argument("lags", nargs="+")
    args = parser.parse_args(argv)
    worse = False
    print("%-18s %-20s %10s %10s %8s" % ("model", "discretization", "pardel", "sympy", "ratio"))
    with tempfile.TemporaryDirectory() as tmp:
        for lag in args.lags:
            counts = pardel_counts(args.pardel_gen, lag, tmp)
            model = os.path.splitext(os.path.basename(lag))[0]
            for disc, (ours, reported) in counts.items():
                c_path = os.path.join(tmp, "peer.c")
                try:
                    subprocess.run([sys.executable, PEER, "--model", lag, "--disc", disc, "--function", "f",
                                    "--out", c_path], check=True, timeout=args.timeout)
                    with open(c_path) as f:
                        theirs = ops_of_c_function(f.read())
                    ratio = "%.2f" % (ours / theirs) if theirs else "-"
                    worse = worse or ours > theirs
                    print("%-18s %-20s %10d %10d %8s" % (model, disc, ours, theirs, ratio), flush=True)
                except subprocess.TimeoutExpired:
                    print("%-18s %-20s %10d %10s %8s" % (model, disc, ours, "timeout", "-"), flush=True)
                if ours != reported:
                    print("  note: text count %d differs from pardel-gen's own count %d" % (ours, reported))
    return 1 if worse else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

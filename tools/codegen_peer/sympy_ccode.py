#!/usr/bin/python3
"""The SymPy peer of pardel-gen: C code for one model's discrete Lagrangian and its derivatives.

For a .lag model and one discretization it builds Ld with sympy_kernels.DiscreteLagrangian,
differentiates it with sympy.diff (D1, D2, D11, D12, D22), applies sympy.cse to the unique
outputs together, and prints them with SymPy's C99 code printer as one function with the
signature of pardel_full_kernel (pardel/kernel_abi.h). Symmetric entries of D11 and D22 are
computed once and copied, as pardel does.

Usage:
  /usr/bin/python3 sympy_ccode.py --model NAME_OR_PATH.lag --disc DISC --function NAME \
      --out FILE.c [--stats FILE.json]
The stats file records SymPy's own operation count (sympy.count_ops) before and after cse.
"""

import argparse
import json
import os
import sys
import time

import sympy
from sympy.printing.c import C99CodePrinter

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sympy_kernels  # noqa: E402


def emit(model, disc, function):
    """Returns (C source text, stats dict)."""
    started = time.time()
    dl = sympy_kernels.DiscreteLagrangian(model, disc)
    m = dl.dim
    ld = dl.action()
    d1 = [sympy.diff(ld, s) for s in dl.q0]
    d2 = [sympy.diff(ld, s) for s in dl.q1]
    # Unique outputs: (target, expression); symmetric copies listed apart.
    targets, exprs, copies = [], [], []
    targets.append("Ld[0]")
    exprs.append(ld)
    for i in range(m):
        targets.append("D1[%d]" % i)
        exprs.append(d1[i])
    for i in range(m):
        targets.append("D2[%d]" % i)
        exprs.append(d2[i])
    for name, grad, wrt, symmetric in (("D11", d1, dl.q0, True), ("D12", d1, dl.q1, False),
                                       ("D22", d2, dl.q1, True)):
        for i in range(m):
            for j in range(m):
                if symmetric and j < i:
                    copies.append(("%s[%d]" % (name, i * m + j), "%s[%d]" % (name, j * m + i)))
                else:
                    targets.append("%s[%d]" % (name, i * m + j))
                    exprs.append(sympy.diff(grad[i], wrt[j]))
    differentiated = time.time()
    ops_before = int(sum(sympy.count_ops(e) for e in exprs))
    replacements, reduced = sympy.cse(exprs, symbols=sympy.numbered_symbols("x"))
    ops_after = int(sum(sympy.count_ops(e) for _, e in replacements) + sum(sympy.count_ops(e) for e in reduced))
    finished = time.time()

    printer = C99CodePrinter()
    lines = ["// SymPy peer of pardel-gen for model %s, discretization %s: sympy.diff, sympy.cse," % (model.name, disc),
             "// C99CodePrinter (written by tools/codegen_peer/sympy_ccode.py).",
             "#include <math.h>",
             "",
             "void %s(double h, double t0, double t1, const double* q0, const double* q1, const double* p," % function,
             "    double* Ld, double* D1, double* D2, double* D11, double* D12, double* D22) {",
             "  (void)h; (void)t0; (void)t1; (void)q0; (void)q1; (void)p;"]
    for sym, e in replacements:
        lines.append("  const double %s = %s;" % (sym, printer.doprint(e)))
    for target, e in zip(targets, reduced):
        lines.append("  %s = %s;" % (target, printer.doprint(e)))
    for target, source in copies:
        lines.append("  %s = %s;" % (target, source))
    lines.append("}")
    stats = {"model": model.name, "disc": disc, "sympy_ops_before_cse": ops_before,
             "sympy_ops_after_cse": ops_after, "temporaries": len(replacements),
             "seconds_diff": round(differentiated - started, 2), "seconds_cse": round(finished - differentiated, 2)}
    return "\n".join(lines) + "\n", stats


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", required=True)
    parser.add_argument("--disc", required=True)
    parser.add_argument("--function", required=True, help="name of the emitted C function")
    parser.add_argument("--out", required=True)
    parser.add_argument("--stats")
    args = parser.parse_args(argv)
    try:
        model = sympy_kernels.parse_lag(sympy_kernels.resolve_model_path(args.model))
        source, stats = emit(model, args.disc, args.function)
    except sympy_kernels.LagError as exc:
        print(exc, file=sys.stderr)
        return 2
    with open(args.out, "w") as f:
        f.write(source)
    if args.stats:
        with open(args.stats, "w") as f:
            json.dump(stats, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""Compares pardel's generated kernels with the independent SymPy evaluation (sympy_kernels.py).

For each model and discretization it draws random points (fixed seed), runs
`pardel kernels --model M --disc D ...` and evaluates the same point with ReferenceKernels
(40-digit arithmetic), and reports the largest relative difference. The difference of one
output block (Ld, D1, D2, D11, D12, D22) is normwise: max_i |pardel_i - ref_i| / max_i |ref_i|.
Every other point overrides each param with a random value within 20% of its default.
Exit status 1 when any difference exceeds --tol (default 1e-10), 2 on bad input.

Usage:
  /usr/bin/python3 check_kernels.py --pardel build/pardel --model fuel_nav --model path/to/m.lag
  /usr/bin/python3 check_kernels.py --pardel build/pardel --all-bundled
"""

import argparse
import glob
import json
import math
import os
import random
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sympy_kernels  # noqa: E402

BLOCKS = ("Ld", "D1", "D2", "D11", "D12", "D22")

# Where to sample each bundled model: coordinate box, box of the stored derivatives (order 2),
# range of h. Models not listed use the defaults; points where L is not real are redrawn.
DEFAULT_SAMPLING = {"coords": (-1.0, 1.0), "derivs": (-1.0, 1.0), "h": (0.05, 0.3), "t0": (0.0, 1.0)}
SAMPLING = {
    "zermelo": {"coords": (0.0, 6.0)},
    "zermelo_tv": {"coords": (0.0, 6.0), "t0": (0.0, 10.0)},
    "fuel_nav": {"coords": (0.0, 6.0), "t0": (0.0, 30.0)},
    "interp_fuel": {"coords": (0.0, 6.0), "t0": (0.0, 60.0)},
    "sphere_geodesic": {"coords": (0.3, 2.8)},
    # Between the Earth (origin) and beyond the Moon (r_M ~ 0.00257 AU), up to about the speed on
    # a geosynchronous orbit (0.1 AU per year/2pi), steps of 0.2 to 3 days.
    "spacecraft": {"coords": (-0.004, 0.004), "derivs": (-0.1, 0.1), "h": (0.0005, 0.005), "t0": (0.0, 0.2)},
}


def _sampling(model):
    spec = dict(DEFAULT_SAMPLING)
    spec.update(SAMPLING.get(model.name, {}))
    return spec


def draw_point(rng, model, reference, vary_params):
    """A random point (h, t0, t1, q0, q1, params) where the reference is defined, and its values."""
    spec = _sampling(model)
    n = len(model.coords)
    defaults = reference.default_params()
    for _ in range(100):
        h = rng.uniform(*spec["h"])
        t0 = rng.uniform(*spec["t0"])
        t1 = t0 + h * rng.uniform(0.5, 2.0)

        def node():
            return [rng.uniform(*spec["coords"]) for _ in range(n)] + \
                   [rng.uniform(*spec["derivs"]) for _ in range(n * (model.order - 1))]
        q0, q1 = node(), node()
        # Keep the mean velocity (q1 - q0)/h at a third of the size of the coordinate box.
        q1[:n] = [a + h * (b - a) / 3 for a, b in zip(q0[:n], q1[:n])]
        params = [p * (1 + 0.2 * rng.uniform(-1, 1)) if vary_params else p for p in defaults]
        try:
            return (h, t0, t1, q0, q1, params), reference.evaluate(h, t0, t1, q0, q1, params)
        except ValueError:
            continue
    raise RuntimeError("no point where model %s is defined in its sampling box" % model.name)


def run_pardel(pardel, model_arg, disc, point, model):
    h, t0, t1, q0, q1, params = point
    fmt = lambda xs: ",".join(repr(float(x)) for x in xs)
    cmd = [pardel, "kernels", "--model", model_arg, "--disc", disc, "--h=" + repr(h), "--t0=" + repr(t0),
           "--t1=" + repr(t1), "--q0=" + fmt(q0), "--q1=" + fmt(q1)]
    for (name, _), value in zip(model.params, params):
        cmd += ["--param", "%s=%r" % (name, value)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if proc.returncode != 0:
        raise RuntimeError("`%s` failed (%d): %s" % (" ".join(cmd), proc.returncode, proc.stderr.strip()))
    return json.loads(proc.stdout)


def _flat(value):
    if isinstance(value, list):
        return [x for v in value for x in _flat(v)]
    return [value]


def block_difference(got, ref):
    """max |got - ref| / max |ref| over one block; inf when pardel's value is missing or not finite."""
    g, r = _flat(got), _flat(ref)
    if len(g) != len(r) or any(x is None or not math.isfinite(x) for x in g):
        return math.inf
    scale = max(abs(x) for x in r)
    diff = max(abs(a - b) for a, b in zip(g, r))
    if scale == 0:
        return diff
    return diff / scale


def check(pardel, model_arg, discs, points, seed, tol, out, reference_path=None):
    path = reference_path or sympy_kernels.resolve_model_path(model_arg)
    model = sympy_kernels.parse_lag(path)
    ok = True
    for disc in discs or model.discretizations:
        reference = sympy_kernels.ReferenceKernels(model, disc)
        rng = random.Random("%d/%s/%s" % (seed, model.name, disc))
        worst, worst_block = 0.0, "Ld"
        for k in range(points):
            point, ref = draw_point(rng, model, reference, vary_params=(k % 2 == 1))
            got = run_pardel(pardel, model_arg, disc, point, model)
            for block in BLOCKS:
                d = block_difference(got.get(block), ref[block])
                if d > worst or math.isnan(d):
                    worst, worst_block = d, block
        passed = worst <= tol
        ok = ok and passed
        print("%-16s %-20s max rel diff %.3g (%s) over %d points: %s"
              % (model.name, disc, worst, worst_block, points, "ok" if passed else "FAIL"), file=out)
        out.flush()
    return ok


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--pardel", required=True, help="the pardel executable")
    parser.add_argument("--model", action="append", default=[], help="bundled name or .lag path (repeatable)")
    parser.add_argument("--all-bundled", action="store_true", help="every lagrangians/*.lag, by bundled name")
    parser.add_argument("--disc", action="append", default=[], help="only these discretizations")
    parser.add_argument("--points", type=int, default=4)
    parser.add_argument("--seed", type=int, default=20240601)
    parser.add_argument("--tol", type=float, default=1e-10)
    parser.add_argument("--reference", help="evaluate the SymPy side from this .lag instead (one --model only; "
                                            "used to show that a wrong model is caught)")
    args = parser.parse_args(argv)
    models = list(args.model)
    if args.all_bundled:
        models += sorted(os.path.basename(p)[:-4]
                         for p in glob.glob(os.path.join(sympy_kernels.PROJECT_ROOT, "lagrangians", "*.lag")))
    if not models:
        parser.error("name at least one --model, or --all-bundled")
    if args.reference and len(models) != 1:
        parser.error("--reference needs exactly one --model")
    ok = True
    try:
        for model_arg in models:
            ok = check(args.pardel, model_arg, args.disc, args.points, args.seed, args.tol, sys.stdout,
                       args.reference) and ok
    except sympy_kernels.LagError as exc:
        print(exc, file=sys.stderr)
        return 2
    except RuntimeError as exc:
        print("error: %s" % exc, file=sys.stderr)
        return 1
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

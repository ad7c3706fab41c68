#!/usr/bin/env python3
"""The seed's block Jacobi-Newton iteration (m = 1) in JAX: a peer of pardel's device
Jacobi-Newton on the same GPU, run the way the seed authors' public JAX code runs the method.

The discrete Lagrangian Ld(q0, q1) is written in jax.numpy (the same formula as pardel's generated
kernels), its derivatives come from jax.grad and jax.hessian, jax.vmap maps them over the intervals
of a trajectory and over the problems of a batch, everything is float64, and a Python loop calls a
jitted function that does `check_every` sweeps of the whole batch, then a jitted convergence test.

Models (lagrangians/*.lag), both autonomous, with pardel's order-1 "trapezoid" discretization
(codegen/src/discretize.cpp, discrete_lagrangian):
    Ld(q0, q1) = h/2 (L(q0, v) + L(q1, v)),  v = (q1 - q0)/h,  h = t1 - t0,
- fuel_nav: L = 1/2 ((x' - W1)^2 + (y' - W2)^2), W1 = cos(2x - y - 6), W2 = 2/3 sin(y) + x - 3;
- zermelo: L = F^2, F the Randers metric of the four-vortex wind scaled by the param s.

One Jacobi-Newton sweep updates every interior node k from its own block, the others held:
    g = D2 Ld(q_{k-1}, q_k) + D1 Ld(q_k, q_{k+1}),  H = D22 Ld(q_{k-1}, q_k) + D11 Ld(q_k, q_{k+1}),
    q_k <- q_k - (1 - eps) H^{-1} g            (eps: the damping; 0 is the plain Newton update).
The end nodes stay fixed. Convergence is pardel's per-problem test (convergence_test below); a
converged problem is frozen at the check that finds it, the others go on.

Input (--batch): the JSON that pardel's GPU benchmark writes: model, discretization ("trapezoid"),
N, t0, T, dim, params (declaration order), B, guesses (raw little-endian float64 (B, N+1, dim),
relative to the JSON's folder, ends included), rtol, tol, damping, max_sweeps, check_every.
The solve is run twice: the first call includes compilation (compile_seconds), the second is timed
alone (solve_seconds, from the first check to the last result on the device; the upload of the
guesses and the download of the result are outside it).

    python3 tools/gpu/jax_peer.py --batch out/gpu/batch.json --json out/gpu/jax.json --solution out/gpu/jax.bin
    python3 tools/gpu/jax_peer.py --sweep-only 10000000 --json out/gpu/jax_sweep.json
    python3 tools/gpu/jax_peer.py --batch out/gpu/batch.json --cpu          # JAX on the CPU instead

--sweep-only N times one jitted sweep of fuel_nav for one problem with N intervals (straight-line
guess from (0, 0) to (6, 5), T = 30): the median of 20 calls after a warm-up.

The numpy helpers (reading the batch, the models with an array-module argument, the assembly of a
sweep and of the residual from per-interval derivatives, the convergence test, the outputs) need no
JAX; jax is imported inside the solver functions only.
"""
import argparse
import json
import os
import sys
import time

import numpy as np

EPS = float(np.finfo(np.float64).eps)
MODELS = ("fuel_nav", "zermelo")


# ----------------------------------------------------------------------------- models


def lagrangian(model, q, v, params, xp):
    """L(q, v) of a model for one point: q, v of shape (2,); xp is numpy or jax.numpy."""
    x, y = q[0], q[1]
    xd, yd = v[0], v[1]
    if model == "fuel_nav":
        w1 = xp.cos(2 * x - y - 6)
        w2 = 2.0 / 3.0 * xp.sin(y) + x - 3
        return 0.5 * ((xd - w1) ** 2 + (yd - w2) ** 2)
    if model == "zermelo":
        s = params[0]
        d22 = 3 * ((x - 2) ** 2 + (y - 2) ** 2) + 1
        d44 = 3 * ((x - 4) ** 2 + (y - 4) ** 2) + 1
        d25 = 3 * ((x - 2) ** 2 + (y - 5) ** 2) + 1
        d51 = 3 * ((x - 5) ** 2 + (y - 1) ** 2) + 1
        w1 = s * ((y - 2) / d22 + (y - 4) / d44 + (y - 5) / d25 - (y - 1) / d51)
        w2 = s * (-(x - 2) / d22 - (x - 4) / d44 - (x - 2) / d25 + (x - 5) / d51)
        alpha = 1 - (w1 ** 2 + w2 ** 2)
        wv = w1 * xd + w2 * yd
        f = xp.sqrt((xd ** 2 + yd ** 2) / alpha + wv ** 2 / alpha ** 2) - wv / alpha
        return f ** 2
    raise ValueError("unknown model %r (expected one of %s)" % (model, ", ".join(MODELS)))


def discrete_lagrangian(model, q0, q1, h, params, xp):
    """pardel's order-1 trapezoid: h/2 (L(t0, q0, v) + L(t1, q1, v)), v = (q1 - q0)/h (both models
    are autonomous, so the times do not enter)."""
    v = (q1 - q0) / h
    return h / 2 * (lagrangian(model, q0, v, params, xp) + lagrangian(model, q1, v, params, xp))


# ----------------------------------------------------------------------------- assembly


def node_blocks(G, Hm, d):
    """Per-interval derivatives to per-node ones for the interior nodes k = 1..N-1.
    G: (N, 2d), the gradient of Ld(q_k, q_{k+1}) in (q_k, q_{k+1}); Hm: (N, 2d, 2d) its Hessian.
    Returns D2 Ld(q_{k-1}, q_k), D1 Ld(q_k, q_{k+1}) (each (N-1, d)) and the block
    H_k = D22 Ld(q_{k-1}, q_k) + D11 Ld(q_k, q_{k+1}) ((N-1, d, d)), or None without Hm."""
    d2 = G[:-1, d:]
    d1 = G[1:, :d]
    blocks = None if Hm is None else Hm[:-1, d:, d:] + Hm[1:, :d, :d]
    return d2, d1, blocks


def residual_stats(G, d, xp):
    """Per component: max_k |r_k,i| and max_k (|D2_i| + |D1_i|) over the interior nodes."""
    d2, d1, _ = node_blocks(G, None, d)
    r = d2 + d1
    return xp.max(xp.abs(r), axis=0), xp.max(xp.abs(d2) + xp.abs(d1), axis=0)


def solve_small(blocks, g, xp):
    """Solves blocks[k] x_k = g_k for every k (blocks (M, d, d), g (M, d))."""
    return xp.linalg.solve(blocks, g[..., None])[..., 0]


def sweep_update(q, G, Hm, damping, xp):
    """One Jacobi-Newton sweep of one trajectory q ((N+1, d)) from its interval derivatives."""
    d = q.shape[-1]
    d2, d1, blocks = node_blocks(G, Hm, d)
    step = solve_small(blocks, d2 + d1, xp)
    interior = q[1:-1] - (1.0 - damping) * step
    return xp.concatenate([q[:1], interior, q[-1:]], axis=0)


def convergence_test(comp_res, comp_scale, start_comp_scale, rtol, tol, xp=np):
    """pardel's test, per problem: arrays (..., d) of max_k |r_k,i|, max_k (|D2_i| + |D1_i|) and
    the latter at the initial guess. Returns (converged (...), max |r| (...)).
    tol > 0: max |r| <= tol. Else max |r| <= max(rtol, 160 eps) * scale (scale the largest
    comp_scale) and each comp_res_i <= max(rtol comp_scale_i, 160 eps comp_scale_i,
    160 eps start_comp_scale_i)."""
    res = xp.max(comp_res, axis=-1)
    if tol > 0:
        return (res <= tol) & xp.all(comp_res <= tol, axis=-1), res
    scale = xp.max(comp_scale, axis=-1)
    target = xp.maximum(rtol * scale, 160 * EPS * scale)
    comp_target = xp.maximum(xp.maximum(rtol * comp_scale, 160 * EPS * comp_scale), 160 * EPS * start_comp_scale)
    return (res <= target) & xp.all(comp_res <= comp_target, axis=-1), res


# ----------------------------------------------------------------------------- input and output


def read_batch(path):
    """The benchmark's batch: its JSON fields, with guesses as a (B, N+1, dim) float64 array."""
    with open(path) as f:
        spec = json.load(f)
    for key in ("model", "N", "t0", "T", "dim", "B", "guesses"):
        if key not in spec:
            raise ValueError("%s: missing key %r" % (path, key))
    if spec["model"] not in MODELS:
        raise ValueError("%s: model %r is not one of %s" % (path, spec["model"], ", ".join(MODELS)))
    disc = spec.get("discretization", "trapezoid")
    if disc != "trapezoid":
        raise ValueError("%s: discretization %r; only trapezoid is implemented" % (path, disc))
    n, dim, b = int(spec["N"]), int(spec["dim"]), int(spec["B"])
    if dim != 2:
        raise ValueError("%s: dim %d; the models have 2 coordinates" % (path, dim))
    params = [float(p) for p in spec.get("params", [])]
    if spec["model"] == "zermelo" and len(params) != 1:
        raise ValueError("%s: zermelo takes one param (s), got %d" % (path, len(params)))
    gpath = os.path.join(os.path.dirname(os.path.abspath(path)), spec["guesses"])
    raw = np.fromfile(gpath, dtype="<f8")
    if raw.size != b * (n + 1) * dim:
        raise ValueError("%s: %d values, expected B (N+1) dim = %d" % (gpath, raw.size, b * (n + 1) * dim))
    return {
        "model": spec["model"],
        "discretization": disc,
        "N": n,
        "t0": float(spec["t0"]),
        "T": float(spec["T"]),
        "dim": dim,
        "params": params,
        "B": b,
        "guesses": raw.reshape(b, n + 1, dim).astype(np.float64),
        "rtol": float(spec.get("rtol", 1e-10)),
        "tol": float(spec.get("tol", 0.0)),
        "damping": float(spec.get("damping", 0.0)),
        "max_sweeps": int(spec.get("max_sweeps", 100000)),
        "check_every": max(1, int(spec.get("check_every", 1))),
    }


def summarize(values):
    values = np.asarray(values)
    if values.size == 0:
        return {"min": None, "median": None, "max": None}
    return {"min": float(np.min(values)), "median": float(np.median(values)), "max": float(np.max(values))}


def finite_or_none(x):
    x = float(x)
    return x if np.isfinite(x) else None


def write_json(path, record):
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    with open(path, "w") as f:
        json.dump(record, f, indent=1)
        f.write("\n")


def write_solution(path, q):
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    np.ascontiguousarray(q, dtype="<f8").tofile(path)


# ----------------------------------------------------------------------------- JAX


def import_jax(cpu):
    if cpu:
        os.environ["JAX_PLATFORMS"] = "cpu"
    import jax

    if cpu:
        jax.config.update("jax_platforms", "cpu")
    jax.config.update("jax_enable_x64", True)
    return jax


def device_name(jax):
    dev = jax.devices()[0]
    return getattr(dev, "device_kind", None) or str(dev)


def make_functions(jax, model, params, h, damping, rtol, tol):
    """The jitted functions of a batch: sweeps(q, frozen, n) does n sweeps of the problems not frozen
    (n a Python int, traced: one compilation serves every n); check(q, start_comp_scale) returns
    (converged, max |r|, comp_scale) per problem (a start_comp_scale of NaN: the comp_scale of q);
    sweep_one(q) is one sweep of one problem."""
    import jax.numpy as jnp
    from jax import lax

    params = tuple(float(p) for p in params)

    def ld(z):
        d = z.shape[0] // 2
        return discrete_lagrangian(model, z[:d], z[d:], h, params, jnp)

    grad_i = jax.vmap(jax.grad(ld))      # over intervals: (N, 2d) -> (N, 2d)
    hess_i = jax.vmap(jax.hessian(ld))   # over intervals: (N, 2d) -> (N, 2d, 2d)

    def intervals(q):
        return jnp.concatenate([q[:-1], q[1:]], axis=1)

    def sweep_one(q):
        z = intervals(q)
        return sweep_update(q, grad_i(z), hess_i(z), damping, jnp)

    def stats_one(q):
        return residual_stats(grad_i(intervals(q)), q.shape[-1], jnp)

    sweep_batch = jax.vmap(sweep_one)
    stats_batch = jax.vmap(stats_one)

    @jax.jit
    def sweeps(q, frozen, n):
        def body(_, qc):
            return jnp.where(frozen[:, None, None], qc, sweep_batch(qc))

        return lax.fori_loop(0, n, body, q)

    @jax.jit
    def check(q, start_comp_scale):
        comp_res, comp_scale = stats_batch(q)
        start = jnp.where(jnp.isnan(start_comp_scale), comp_scale, start_comp_scale)
        conv, res = convergence_test(comp_res, comp_scale, start, rtol, tol, jnp)
        return conv, res, comp_scale

    return sweeps, check, jax.jit(sweep_one)


def solve_batch(fns, q_dev, max_sweeps, check_every):
    """The Python loop around the jitted sweeps. Returns (q, converged, sweeps, residual) with q on
    the device (block_until_ready done) and the rest numpy arrays."""
    import jax.numpy as jnp

    sweeps_fn, check_fn, _ = fns
    b, _, d = q_dev.shape
    q = q_dev
    conv, res, start_cs = check_fn(q, jnp.full((b, d), jnp.nan))
    conv = np.asarray(conv)
    res = np.asarray(res)
    frozen = conv.copy()
    done_at = np.zeros(b, dtype=np.int64)
    done = 0
    while done < max_sweeps and not frozen.all():
        n = min(check_every, max_sweeps - done)
        q = sweeps_fn(q, jnp.asarray(frozen), n)
        done += n
        conv, res, _ = check_fn(q, start_cs)
        conv = np.asarray(conv)
        res = np.asarray(res)
        done_at[~frozen] = done
        frozen = frozen | conv
    q.block_until_ready()
    return q, frozen, done_at, res


def run_batch(args):
    spec = read_batch(args.batch)
    jax = import_jax(args.cpu)
    import jax.numpy as jnp

    h = spec["T"] / spec["N"]
    fns = make_functions(jax, spec["model"], spec["params"], h, spec["damping"], spec["rtol"], spec["tol"])
    guesses = spec["guesses"]

    warm = jax.device_put(jnp.asarray(guesses.copy()))
    warm.block_until_ready()
    start = time.perf_counter()
    solve_batch(fns, warm, spec["max_sweeps"], spec["check_every"])
    compile_seconds = time.perf_counter() - start

    q0 = jax.device_put(jnp.asarray(guesses))
    q0.block_until_ready()
    start = time.perf_counter()
    q, converged, sweeps, res = solve_batch(fns, q0, spec["max_sweeps"], spec["check_every"])
    solve_seconds = time.perf_counter() - start
    q_host = np.asarray(q)

    record = {
        "model": spec["model"],
        "discretization": spec["discretization"],
        "N": spec["N"],
        "B": spec["B"],
        "device": device_name(jax),
        "platform": jax.devices()[0].platform,
        "jax_version": jax.__version__,
        "damping": spec["damping"],
        "check_every": spec["check_every"],
        "max_sweeps": spec["max_sweeps"],
        "compile_seconds": compile_seconds,
        "solve_seconds": solve_seconds,
        "converged": int(converged.sum()),
        "all_converged": bool(converged.all()),
        "sweeps": summarize(sweeps),
        "max_residual": finite_or_none(np.max(res)) if res.size else None,
        "per_problem": {
            "converged": [bool(c) for c in converged],
            "sweeps": [int(s) for s in sweeps],
            "residual": [finite_or_none(r) for r in res],
        },
    }
    if args.json:
        write_json(args.json, record)
    if args.solution:
        write_solution(args.solution, q_host)
    print("jax_peer %s N=%d B=%d on %s: %d/%d converged, sweeps %s..%s (median %s), max residual %.3g, "
          "first call %.3f s (with compilation), solve %.4f s"
          % (spec["model"], spec["N"], spec["B"], record["device"], record["converged"], spec["B"],
             record["sweeps"]["min"], record["sweeps"]["max"], record["sweeps"]["median"],
             np.max(res) if res.size else float("nan"), compile_seconds, solve_seconds))
    return 0 if converged.all() else 1


def straight_line(n, a, b):
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    return (1 - s) * np.asarray(a, dtype=np.float64) + s * np.asarray(b, dtype=np.float64)


def run_sweep_only(args):
    n = args.sweep_only
    jax = import_jax(args.cpu)
    import jax.numpy as jnp

    T = 30.0
    fns = make_functions(jax, "fuel_nav", [], T / n, 0.0, 1e-10, 0.0)
    sweep_one = fns[2]
    q = jax.device_put(jnp.asarray(straight_line(n, [0.0, 0.0], [6.0, 5.0])))
    q.block_until_ready()
    start = time.perf_counter()
    sweep_one(q).block_until_ready()
    compile_seconds = time.perf_counter() - start
    sweep_one(q).block_until_ready()
    times = []
    for _ in range(args.repeat):
        start = time.perf_counter()
        sweep_one(q).block_until_ready()
        times.append(time.perf_counter() - start)
    median = float(np.median(times))
    record = {
        "mode": "sweep",
        "model": "fuel_nav",
        "discretization": "trapezoid",
        "N": n,
        "B": 1,
        "T": T,
        "device": device_name(jax),
        "platform": jax.devices()[0].platform,
        "jax_version": jax.__version__,
        "compile_seconds": compile_seconds,
        "repeat": args.repeat,
        "sweep_seconds_median": median,
        "sweep_seconds_min": float(np.min(times)),
        "sweep_seconds": times,
        "ns_per_node": median / max(n - 1, 1) * 1e9,
    }
    if args.json:
        write_json(args.json, record)
    print("jax_peer sweep fuel_nav N=%d on %s: median %.4f s (min %.4f s) of %d, %.2f ns per node, first call %.3f s"
          % (n, record["device"], median, record["sweep_seconds_min"], args.repeat, record["ns_per_node"],
             compile_seconds))
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(description="The seed's block Jacobi-Newton iteration in JAX, the peer of "
                                     "pardel's device Jacobi-Newton.")
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--batch", help="the benchmark's batch JSON")
    mode.add_argument("--sweep-only", type=int, metavar="N", help="time one sweep of fuel_nav with N intervals")
    parser.add_argument("--json", help="write the results to this JSON file")
    parser.add_argument("--solution", help="write the final iterates, raw float64 (B, N+1, dim)")
    parser.add_argument("--cpu", action="store_true", help="run JAX on the CPU")
    parser.add_argument("--repeat", type=int, default=20, help="timed calls of --sweep-only (default 20)")
    args = parser.parse_args(argv)
    if args.sweep_only is not None:
        if args.sweep_only < 2:
            parser.error("--sweep-only needs N >= 2")
        return run_sweep_only(args)
    return run_batch(args)


if __name__ == "__main__":
    sys.exit(main())

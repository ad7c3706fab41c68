"""Solves in other processes: a softening Duffing oscillator driven by a periodic force, built with
SymPy (L = x'^2/2 - k x^2/2 + beta x^4/4 + F cos(Omega t) x), solved for several forcing
amplitudes by a concurrent.futures.ProcessPoolExecutor. The model and the results cross
between processes by pickle (a Model pickles as its .lag text, which each worker loads from the
cache; a Result pickles whole); the answers are checked against the same solves in this process
(usage: process_pool.py [--out DIR])."""
import argparse
import concurrent.futures
import multiprocessing
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import sympy as sp  # noqa: E402

import pardel  # noqa: E402


def solve_one(model, F):
    """Runs in a worker: `model` arrives unpickled (loaded again there), the Result goes back pickled."""
    return pardel.solve(model, q0=[0], qN=[0.5], T=2, N=100, params={"F": F}, threads=1)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="out/python/process_pool")
    out = parser.parse_args().out
    os.makedirs(out, exist_ok=True)

    t = sp.Symbol("t")
    x = sp.Function("x")(t)
    k, beta, F, Omega = sp.symbols("k beta F Omega")
    L = x.diff(t) ** 2 / 2 - k * x ** 2 / 2 + beta * x ** 4 / 4 + F * sp.cos(Omega * t) * x
    model = pardel.model_from_sympy(L, [x], {k: 1, beta: 1, F: 0, Omega: 2}, name="forced_duffing")
    print(model.lag_text)

    amplitudes = [0.0, 0.25, 0.5, 0.75, 1.0, 1.25]
    # "spawn": each worker is a fresh interpreter, so the model really is loaded again from its text.
    with concurrent.futures.ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        results = list(pool.map(solve_one, [model] * len(amplitudes), amplitudes))
    for amplitude, r in zip(amplitudes, results):
        here = solve_one(model, amplitude)
        print("F = %.2f: %s" % (amplitude, r))
        assert r.converged and np.array_equal(r.q, here.q) and r.action == here.action

    _, ax = plt.subplots()
    for amplitude, r in zip(amplitudes, results):
        ax.plot(r.t, r.coordinate("x"), label="F = %g" % amplitude)
    ax.set_xlabel("t")
    ax.set_ylabel("x")
    ax.legend()
    ax.figure.savefig(os.path.join(out, "forced_duffing.png"))
    print("plot in", out)

"""Warm starts: solve the fuel-optimal navigation problem of scenes/fuel_nav.toml once from the
straight line, then reuse the answer as the initial guess for a nearby final time and for a finer
grid, and compare the Newton iterations with cold starts of the same problems
(usage: warm_start.py [--out DIR])."""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pardel  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/warm_start")
out = parser.parse_args().out
os.makedirs(out, exist_ok=True)

problem = dict(q0=[0, 0], qN=[6, 5])  # from (0, 0) to (6, 5) through the wind of the fuel_nav model

# 1. The first solve, from the default guess (the straight line between the end points).
first = pardel.solve("fuel_nav", T=30, N=200, **problem)
print("T = 30, N = 200, cold:", first)


def compare(what, cold, warm):
    """Both solves must reach the same minimum; the warm one should need fewer iterations."""
    print("%s\n  cold: %s\n  warm: %s" % (what, cold, warm))
    assert cold.converged and warm.converged
    assert abs(warm.cost - cold.cost) <= 1e-9 * abs(cold.cost)  # the same fuel, to the solver's tolerance
    assert np.max(np.abs(warm.q - cold.q)) < 1e-4  # the same path (a flat minimum: positions settle slowest)
    assert warm.iterations < cold.iterations
    print("  iterations %d -> %d" % (cold.iterations, warm.iterations))


# 2. A nearby parameter: the final time 29 instead of 30. guess= takes a Result (or an array of
# its node values); the solve starts from that path instead of the straight line.
compare("T = 29, N = 200:",
        pardel.solve("fuel_nav", T=29, N=200, **problem),
        pardel.solve("fuel_nav", T=29, N=200, guess=first, **problem))

# 3. A finer grid: a guess on another grid is resampled to the new N (here 200 -> 400 intervals).
fine_cold = pardel.solve("fuel_nav", T=30, N=400, **problem)
fine_warm = pardel.solve("fuel_nav", T=30, N=400, guess=first, **problem)
compare("T = 30, N = 400:", fine_cold, fine_warm)

_, ax = plt.subplots()
for label, r in (("cold", fine_cold), ("warm", fine_warm)):
    residual = np.asarray(r.history["residual"])
    ax.semilogy(r.history["iteration"], np.where(residual > 0, residual, np.nan), ".-", label="%s start" % label)
ax.set_xlabel("iteration")
ax.set_ylabel("DEL residual")
ax.set_title("fuel_nav, T = 30, N = 400")
ax.legend()
ax.figure.savefig(os.path.join(out, "cold_vs_warm.png"))
print("plot in", out)

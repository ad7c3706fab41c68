"""Vary a model's parameter: the bundled Bratu model (u'' + lambda e^u = 0, u(0) = u(1) = 0) solved
for lambda from 0.25 up to 3.4, close to the fold at lambda = 3.5138 beyond which no solution
exists, each solve started from the previous answer; every answer is checked against the
closed-form lower solution (usage: vary_parameter.py [--out DIR])."""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

import pardel  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/vary_parameter")
out = parser.parse_args().out
os.makedirs(out, exist_ok=True)

model = pardel.model("bratu")
print(model)  # params {'lambda': 1.0}: the default, replaced by params= in each solve


def exact(lam, t):
    """The lower solution u = -2 log(cosh((t - 1/2) theta/2) / cosh(theta/4)), where theta is the
    smaller root of theta = sqrt(2 lambda) cosh(theta/4) (docs/models.md); the larger root, above
    theta = 4.7987 (the fold), gives the upper solution."""
    theta = brentq(lambda x: x - np.sqrt(2 * lam) * np.cosh(x / 4), 0, 4.7987)
    return -2 * np.log(np.cosh((t - 0.5) * theta / 2) / np.cosh(theta / 4))


lambdas = np.linspace(0.25, 3.4, 10)
previous, peaks = None, []
for lam in lambdas:
    # params= overrides the model's defaults by name; guess= starts from the previous answer.
    # The default discretization, trapezoid, is second order: doubling N should divide the error
    # at the nodes by 4, which is the check (the error itself grows toward the fold).
    coarse = pardel.solve(model, q0=[0], qN=[0], T=1, N=100, params={"lambda": lam}, guess=previous)
    fine = pardel.solve(model, q0=[0], qN=[0], T=1, N=200, params={"lambda": lam}, guess=coarse)
    errors = [np.max(np.abs(r.q[:, 0] - exact(lam, r.t))) for r in (coarse, fine)]
    print("lambda = %.3f: %s; error %.2e (N = 100), %.2e (N = 200), ratio %.3f" % (
        lam, coarse, errors[0], errors[1], errors[0] / errors[1]))
    assert coarse.converged and fine.converged
    assert errors[0] < 1e-3 and 3.5 < errors[0] / errors[1] < 4.5
    previous = coarse
    peaks.append(coarse.q[50, 0])  # u(1/2), the node in the middle

# The whole solution curve, both branches, from the closed form: lambda and u(1/2) as functions of
# theta; pardel's answers lie on its lower branch.
theta = np.linspace(0.01, 12, 400)
_, ax = plt.subplots()
ax.plot(theta ** 2 / (2 * np.cosh(theta / 4) ** 2), 2 * np.log(np.cosh(theta / 4)), "k-", lw=1, label="exact")
ax.plot(lambdas, peaks, "o", label="pardel, N = 100")
ax.set_xlabel("lambda")
ax.set_ylabel("u(1/2)")
ax.legend()
ax.figure.savefig(os.path.join(out, "bratu_branch.png"))
print("plot in", out)

"""Solve a model you wrote yourself: a bead sliding without friction on a circular hoop that spins
about its vertical diameter, written as .lag text in a temporary folder outside the checkout,
solved as a boundary-value problem and checked against SciPy's solve_bvp on the Euler-Lagrange
equation (usage: solve_own_model.py [--out DIR])."""
import argparse
import os
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.integrate import solve_bvp  # noqa: E402

import pardel  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/solve_own_model")
out = os.path.abspath(parser.parse_args().out)
os.makedirs(out, exist_ok=True)

# The model, in the .lag format of docs/models.md. theta is the bead's angle from the bottom of the
# hoop, w the hoop's angular velocity, g_over_R gravity over the hoop's radius; per unit m R^2 the
# Lagrangian is kinetic energy (along the hoop and from the spin) minus the potential energy:
#   L = theta'^2/2 + w^2 sin(theta)^2/2 + (g/R) cos(theta),
# whose Euler-Lagrange equation is theta'' = w^2 sin(theta) cos(theta) - (g/R) sin(theta).
LAG = """# A bead on a hoop spinning at angular velocity w about its vertical diameter.
model bead_on_hoop
coords theta
param w = 2
param g_over_R = 1
L = 1/2*theta'^2 + 1/2*w^2*sin(theta)^2 + g_over_R*cos(theta)
discretizations midpoint trapezoid
"""
w, g_over_R = 2.0, 1.0
theta0, thetaT, T = 0.2, 1.5, 2.0  # from theta = 0.2 at t = 0 to theta = 1.5 at t = T

home = os.getcwd()
with tempfile.TemporaryDirectory() as folder:
    os.chdir(folder)  # a working folder outside the checkout: nothing here needs the sources
    try:
        with open("bead_on_hoop.lag", "w") as f:
            f.write(LAG)
        # A path ending in .lag loads that file; the first load compiles it (a second or two), later
        # loads find it in the cache (pardel.lag_cache_dir()). pardel.model(LAG) loads the text itself.
        model = pardel.model("bead_on_hoop.lag")
        print(model)
        # The default discretization is the first listed, midpoint: a second-order method, so the
        # error at the nodes falls by about 4 each time N doubles.
        results = [pardel.solve(model, q0=[theta0], qN=[thetaT], T=T, N=N) for N in (50, 100, 200)]
    finally:
        os.chdir(home)


# The independent truth: SciPy's collocation solver on the first-order form of the
# Euler-Lagrange equation, to a tolerance far below the discretization error.
def rhs(t, y):
    return np.vstack([y[1], w ** 2 * np.sin(y[0]) * np.cos(y[0]) - g_over_R * np.sin(y[0])])


def ends(ya, yb):
    return np.array([ya[0] - theta0, yb[0] - thetaT])


t = np.linspace(0, T, 11)
truth = solve_bvp(rhs, ends, t, np.vstack([theta0 + (thetaT - theta0) * t / T, np.full_like(t, (thetaT - theta0) / T)]),
                  tol=1e-10, max_nodes=100000)
assert truth.status == 0, truth.message

errors = []
for r in results:
    error = np.max(np.abs(r.q[:, 0] - truth.sol(r.t)[0]))
    errors.append(error)
    print("N = %3d: %s\n         error against solve_bvp %.3e, pardel's own estimate %.3e" % (
        r.N, r, error, r.error_estimate))
    assert r.converged
    # The Richardson estimate of the result should be the true error to within a factor 2.
    assert 0.5 * error <= r.error_estimate <= 2 * error
ratios = [errors[i] / errors[i + 1] for i in range(len(errors) - 1)]
print("error ratios when N doubles:", " ".join("%.3f" % x for x in ratios), "(second order: 4)")
assert all(3.5 < x < 4.5 for x in ratios)
assert errors[-1] < 1e-5  # h = 0.01: C h^2 with C below 0.1 for this smooth solution

_, ax = plt.subplots()
ax.plot(results[-1].t, results[-1].q[:, 0], "-", label="pardel, N = %d" % results[-1].N)
ax.plot(results[0].t, truth.sol(results[0].t)[0], "k.", ms=3, label="solve_bvp")
ax.set_xlabel("t")
ax.set_ylabel("theta")
ax.legend()
ax.figure.savefig(os.path.join(out, "bead_on_hoop.png"))
print("plot in", out)

"""A model built with SymPy: a double pendulum whose Lagrangian is derived from the positions of its
two bobs, turned into a pardel model by pardel.model_from_sympy, solved from one configuration to
another, and checked against SciPy's solve_bvp on the Euler-Lagrange equations that SymPy derives
from the same Lagrangian (usage: sympy_model.py [--out DIR])."""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import sympy as sp  # noqa: E402
from scipy.integrate import solve_bvp  # noqa: E402

import pardel  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="out/python/sympy_model")
out = parser.parse_args().out
os.makedirs(out, exist_ok=True)

# The Lagrangian, from the mechanics: two point masses on massless rods, angles from the downward
# vertical, the second rod hanging from the first bob.
t = sp.Symbol("t")
a, b = sp.Function("a")(t), sp.Function("b")(t)  # the coordinates: functions of the time symbol
m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g")
x1, y1 = l1 * sp.sin(a), -l1 * sp.cos(a)
x2, y2 = x1 + l2 * sp.sin(b), y1 - l2 * sp.cos(b)
kinetic = m1 / 2 * (x1.diff(t) ** 2 + y1.diff(t) ** 2) + m2 / 2 * (x2.diff(t) ** 2 + y2.diff(t) ** 2)
potential = m1 * g * y1 + m2 * g * y2
L = sp.trigsimp(sp.expand(kinetic - potential))  # sin^2 + cos^2 = 1, cos(a)cos(b) + sin(a)sin(b) = cos(a - b)
defaults = {m1: 1, m2: 1, l1: 1, l2: 1, g: 9.81}

# model_from_sympy prints L as .lag text (x.diff(t) becomes x') and compiles it like a .lag file.
model = pardel.model_from_sympy(L, [a, b], defaults, name="double_pendulum",
                                discretizations=["midpoint", "galerkin_gauss(s=2)"])
print(model.lag_text)

# From (a, b) = (0.3, -0.2) to (0.5, 0.4) in 0.5 s, with two discretizations: midpoint (order 2)
# and galerkin_gauss(s=2) (order 4, docs/discretizations.md).
q0, qN, T, N = [0.3, -0.2], [0.5, 0.4], 0.5, 100
results = {d: pardel.solve(model, q0=q0, qN=qN, T=T, N=N, discretization=d) for d in model.discretizations}

# The independent truth: SymPy's Euler-Lagrange equations d/dt dL/dq' = dL/dq, solved for the
# accelerations and integrated by SciPy's collocation solver to a tolerance (1e-10) below the
# discretization errors.
Ls = L.subs(defaults)
equations = sp.euler_equations(Ls, [a, b], t)
accelerations = sp.solve([e.lhs - e.rhs for e in equations], [a.diff(t, 2), b.diff(t, 2)], dict=True)[0]
pa, pb, va, vb = sp.symbols("pa pb va vb")  # plain symbols for the angles and velocities, for lambdify
plain = [accelerations[c.diff(t, 2)].subs({a.diff(t): va, b.diff(t): vb}).subs({a: pa, b: pb}) for c in (a, b)]
accelerations_of = sp.lambdify([pa, pb, va, vb], plain)


def rhs(_, y):  # y = (a, b, a', b') at each collocation point
    return np.vstack([y[2], y[3], *accelerations_of(*y)])


def ends(ya, yb):
    return np.array([ya[0] - q0[0], ya[1] - q0[1], yb[0] - qN[0], yb[1] - qN[1]])


mesh = np.linspace(0, T, 21)  # solve_bvp's first mesh and guess: the straight line
line = np.array(q0)[:, None] + np.outer(np.subtract(qN, q0), mesh / T)
truth = solve_bvp(rhs, ends, mesh, np.vstack([line, np.tile(np.subtract(qN, q0)[:, None] / T, len(mesh))]),
                  tol=1e-10, max_nodes=100000)
assert truth.status == 0, truth.message

h = T / N
for d, r in results.items():
    error = np.max(np.abs(r.q - truth.sol(r.t)[:2].T))
    print("%-20s %s\n%-20s error against solve_bvp %.2e, pardel's own estimate %.2e" % (d, r, "", error,
                                                                                      r.error_estimate))
    assert r.converged
    # The error of an order-p method is C h^p; here h = 0.005 and C is about 1 (midpoint, p = 2) and
    # 3 (galerkin_gauss(s=2), p = 4). A wrong model or a lower order would exceed 10 h^p.
    assert error < 10 * h ** (2 if d == "midpoint" else 4)

_, ax = plt.subplots()
r = results["midpoint"]
for i, name in enumerate(r.coords):
    ax.plot(r.t, r.q[:, i], "-", label="%s, pardel (midpoint)" % name)
    ax.plot(r.t[::5], truth.sol(r.t[::5])[i], "k.", ms=3)
ax.set_xlabel("t")
ax.set_ylabel("angle")
ax.set_title("double pendulum (dots: solve_bvp)")
ax.legend()
ax.figure.savefig(os.path.join(out, "double_pendulum.png"))
print("plot in", out)

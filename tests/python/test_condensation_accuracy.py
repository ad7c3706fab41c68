"""The interior values of a Galerkin interval are solved to the rounding of their coordinates:
the interval's derivatives D1 and D2 are first order in their error (the envelope values at the
interior solution). A geodesic on a torus past its conjugate point (a saddle of index 1) under
galerkin_gauss(s=5) carried node errors up to 6.7e-11, erratic in N, where the interior Newton
stopped on a prediction of its next step taken from a step before its quadratic regime (one
interval's D1 2.5e-11 off, relative). Truth: the geodesic equations integrated node to node by
scipy's DOP853 at rtol 1e-13."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import pardel

TORUS_LAG = """\
# geodesics of the torus of radii R and r, by the energy
model torus_geodesic_condensation
coords th ph
param R = 2
param r = 1
L = 1/2*((R + r*cos(th))^2*ph'^2 + r^2*th'^2)
discretizations galerkin_gauss(s=5)
"""


def geodesic(t, y):
    th, ph, dth, dph = y
    rho = 2 + np.cos(th)
    return [dth, dph, -rho * np.sin(th) * dph ** 2, 2 * np.sin(th) * dth * dph / rho]


def nodal_truth(times, y0):
    """The geodesic's coordinates at each node, integrated from one node to the next."""
    y = np.array(y0, float)
    out = [y[:2].copy()]
    for a, b in zip(times[:-1], times[1:]):
        y = solve_ivp(geodesic, (a, b), y, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
        out.append(y[:2].copy())
    return np.array(out)


@pytest.mark.parametrize("N", [18, 24])
def test_galerkin_interior_values_are_solved_to_the_rounding(N):
    y0, T = [0.3, 0.0, 1.3, 0.6], 4.0
    times = np.linspace(0, T, N + 1)
    truth = nodal_truth(times, y0)
    r = pardel.solve(TORUS_LAG, q0=list(truth[0]), qN=list(truth[-1]), T=T, N=N, guess=truth,
                     discretization="galerkin_gauss(s=5)", method="stationary-newton")
    assert r.status == "converged" and r.point["kind"] == "saddle" and r.point["inertia"]["negative"] == 1, r.message
    assert np.abs(r.q - truth).max() < 1e-11

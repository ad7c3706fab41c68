"""An order-4 model on fine grids, where the Hessian's condition (about N^8) is beyond double
precision: L = (x''''^2 + x^2)/2 on [0, 5], whose motion x = Re exp(r t), r = exp(i pi/8), the
discretization holds only up to its truncation error. Newton stands at the round-off level of the
double residual with a derivative component above its own target; iterative refinement in
extended precision takes it the rest of the way. Every grid from 200 to 1000 intervals converges
to the exact motion within 1e-9, under three Hermite-Gauss rules (at N = 1000 hermite_gauss(s=5)
had stalled after 800 iterations at an error of 8)."""
import cmath
import math

import numpy as np
import pytest

import pardel

SNAP_LAG = """\
# L = (x''''^2 + x^2)/2: x'''''''' = -x
model snap_spring_test
order 4
coords x
L = 1/2*(x''''^2 + x^2)
discretizations hermite_gauss(s=4) hermite_gauss(s=5) hermite_gauss(s=6)
"""
T = 5.0
R = cmath.exp(1j * math.pi / 8)


def jet(t):
    """x and its first three derivatives at t."""
    return [(R ** k * cmath.exp(R * t)).real for k in range(4)]


@pytest.mark.parametrize("discretization", ["hermite_gauss(s=4)", "hermite_gauss(s=5)", "hermite_gauss(s=6)"])
def test_fine_grids_converge_to_the_exact_motion(discretization):
    for N in (200, 640, 1000):
        r = pardel.solve(SNAP_LAG, q0=jet(0.0), qN=jet(T), T=T, N=N, discretization=discretization,
                         method="newton", rtol=1e-15, error_estimate=False)
        assert r.status == "converged", (N, r.message)
        exact = np.array([jet(t)[0] for t in r.t])
        error = np.abs(r.q[:, 0] - exact).max()
        assert error <= 1e-9, (N, discretization, error, r.message)
        assert r.iterations < 50, (N, r.iterations)

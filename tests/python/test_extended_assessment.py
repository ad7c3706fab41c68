"""The kind of point on fine grids of order-3 models, whose node Hessian has a condition number of
about N^6 (1e18 at N = 1000): counted in double precision, round-off in its pivots made negative
ones, and a strictly convex action was called a saddle of index 2 at N = 1000 under
galerkin_gauss(s=4) (a minimum at N = 400 and 2000). The assessment is now redone with the
Hessian in extended precision wherever the double one finds no minimum or a minimum beyond its
precision. Independent truth: a strictly convex action has only minima; a saddle's index is the
number of eigenvalues of the second variation below the load, from a Legendre-Galerkin
eigenproblem written here."""
import numpy as np
import pytest
from numpy.polynomial import Polynomial, legendre

import pardel

CONVEX_LAG = """\
# x'''^2/2 + b x'^2/2 + x^4/4 - f x: strictly convex in x; x = X = sin t + t^3/5
model convex_jerk_fine
order 3
coords x
param b = 2
let X = sin(t) + 1/5*t^3
L = 1/2*x'''^2 + b/2*x'^2 + 1/4*x^4 - (X^3 + (1+b)*sin(t) - 6/5*b*t)*x
discretizations hermite_gauss(s=4) galerkin_gauss(s=4) galerkin_lobatto(s=4)
"""

LOADED_LAG = """\
# x'''^2/2 - c x^2/2 - (1 - c) sin(t) x: x'''''' = -c x - (1 - c) sin t, solved by x = sin t
model loaded_jerk_fine
order 3
coords x
param c = 30000
L = 1/2*x'''^2 - c/2*x^2 - (1 - c)*sin(t)*x
discretizations hermite_gauss(s=4) galerkin_gauss(s=4)
"""


def convex_jet(t):
    return [np.sin(t) + 0.2 * t ** 3, np.cos(t) + 0.6 * t ** 2, -np.sin(t) + 1.2 * t]


def sine_jet(t):
    return [np.sin(t), np.cos(t), -np.sin(t)]


def clamped_eigenvalues(T, K=18):
    """The smallest eigenvalues of int v'''^2 = lambda int v^2 over v with v, v', v'' zero at 0 and
    T, by Galerkin's method on s^3 (1 - s)^3 P_k(s), s = t / T (Gauss-Legendre quadrature)."""
    x, w = legendre.leggauss(80)
    s, w = (x + 1) / 2, w * T / 2
    bubble = Polynomial([0, 0, 0, 1]) * Polynomial([1, -1]) ** 3
    basis = [bubble * legendre.Legendre.basis(k, domain=[0, 1]).convert(kind=Polynomial) for k in range(K)]
    V = np.array([p(s) for p in basis])
    V3 = np.array([p.deriv(3)(s) / T ** 3 for p in basis])
    A, M = (V3 * w) @ V3.T, (V * w) @ V.T
    return np.sort(np.linalg.eigvals(np.linalg.solve(M, A)).real)


@pytest.mark.parametrize("discretization,N", [("galerkin_gauss(s=4)", 1000), ("galerkin_gauss(s=4)", 1300),
                                              ("galerkin_lobatto(s=4)", 700), ("galerkin_lobatto(s=4)", 1000),
                                              ("hermite_gauss(s=4)", 1000)])
def test_a_strictly_convex_action_is_a_minimum_on_fine_grids(discretization, N):
    r = pardel.solve(CONVEX_LAG, q0=convex_jet(0.3), qN=convex_jet(2.5), T=2.2, t0=0.3, N=N,
                     discretization=discretization)
    assert r.status == "converged", r.message
    assert r.point["kind"] == "minimum", r.point["note"]
    assert r.point["inertia"]["negative"] == 0 and r.point["lambda_min"] > 0
    assert "extended precision" in r.point["note"]
    assert np.abs(r.q[:, 0] - convex_jet(r.t)[0]).max() < 1e-9


def test_the_index_of_a_saddle_on_a_fine_grid_is_that_of_the_second_variation():
    T, c = 2.0, 30000.0
    eigenvalues = clamped_eigenvalues(T)
    assert np.allclose(eigenvalues[:3], clamped_eigenvalues(T, K=14)[:3], rtol=1e-3)  # resolved
    index = int(np.sum(eigenvalues < c))
    assert index == 2 and eigenvalues[2] > 1.5 * c  # c well inside a gap
    for discretization in ("hermite_gauss(s=4)", "galerkin_gauss(s=4)"):
        r = pardel.solve(LOADED_LAG, q0=sine_jet(0.0), qN=sine_jet(T), T=T, N=1000, discretization=discretization)
        assert r.status == "converged", r.message
        assert r.point["kind"] == "saddle", r.point["note"]
        assert r.point["inertia"]["negative"] == index, r.point["note"]
        assert np.abs(r.q[:, 0] - np.sin(r.t)).max() < 1e-9

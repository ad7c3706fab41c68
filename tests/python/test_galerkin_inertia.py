"""What a Galerkin solve calls its point (minimum or saddle, and the index) is that of the action
over nodes and interior values, checked against that action's Hessian built here independently
(numpy: the degree-S polynomial of each interval in its own Lagrange basis, under S Gauss-Legendre
or S + 1 Gauss-Lobatto points) and, on grids fine enough, against the continuous action's index
(the conjugate points of x'' = -x at multiples of pi). Before, the index counted the condensed node
Hessian alone: x'' = -x over T = 10 under galerkin_gauss(s=4) was said a minimum at N = 3."""
import math

import numpy as np
import pytest

import pardel

OSCILLATOR_LAG = """\
# L = x'^2/2 - w^2 x^2/2: x'' = -w^2 x, conjugate points every pi/w
model oscillator_inertia
coords x
param w = 1
L = x'^2/2 - w^2*x^2/2
discretizations galerkin_gauss(s=4) galerkin_lobatto(s=3) galerkin_gauss(s=3)
"""


def quadrature(kind, S):
    """Points in [0, 1] and weights of a rule of order 2S."""
    if kind == "gauss":
        x, w = np.polynomial.legendre.leggauss(S)
    else:  # Gauss-Lobatto with S + 1 points: the ends and the roots of P_S'
        inner = np.polynomial.legendre.Legendre.basis(S).deriv().roots()
        x = np.concatenate([[-1.0], np.sort(inner.real), [1.0]])
        P = np.polynomial.legendre.Legendre.basis(S)(x)
        w = 2.0 / (S * (S + 1) * P ** 2)
    return (x + 1) / 2, w / 2


def full_action_index(kind, S, N, T, w=1.0):
    """Negative eigenvalues of the Hessian of the Galerkin action of L = x'^2/2 - w^2 x^2/2 over
    the interior nodes and every interval's S - 1 interior values (ends fixed)."""
    nodes = np.linspace(0, 1, S + 1)  # any basis through the ends: the inertia is a congruence invariant
    c, weights = quadrature(kind, S)
    V = np.zeros((len(c), S + 1))
    dV = np.zeros((len(c), S + 1))
    for j in range(S + 1):
        others = np.delete(nodes, j)
        poly = np.poly1d(others, r=True) / np.prod(nodes[j] - others)
        V[:, j] = poly(c)
        dV[:, j] = poly.deriv()(c)
    h = T / N
    local = (dV.T * weights) @ dV / h - w ** 2 * h * (V.T * weights) @ V  # the interval's quadratic form
    n = (N + 1) + N * (S - 1)  # node values, then each interval's interior values
    H = np.zeros((n, n))
    for k in range(N):
        index = [k] + [N + 1 + k * (S - 1) + i for i in range(S - 1)] + [k + 1]
        H[np.ix_(index, index)] += local
    free = [i for i in range(n) if i not in (0, N)]
    eig = np.linalg.eigvalsh(H[np.ix_(free, free)])
    assert np.min(np.abs(eig)) > 1e-8 * np.max(np.abs(eig))  # no eigenvalue near zero: the count is clear
    return int(np.sum(eig < 0)), int(np.sum(eig > 0))


@pytest.mark.parametrize("discretization,kind,S", [("galerkin_gauss(s=4)", "gauss", 4),
                                                   ("galerkin_lobatto(s=3)", "lobatto", 3),
                                                   ("galerkin_gauss(s=3)", "gauss", 3)])
@pytest.mark.parametrize("N", [2, 3, 4, 5, 8, 12])
def test_the_index_is_that_of_the_action_over_nodes_and_interior_values(discretization, kind, S, N):
    T = 10.0
    negative, positive = full_action_index(kind, S, N, T)
    r = pardel.solve(OSCILLATOR_LAG, q0=[1.0], qN=[0.5], T=T, N=N, discretization=discretization)
    assert r.status == "converged", r.message
    point = r.point
    assert point["inertia"]["negative"] == negative, point["note"]
    assert point["inertia"]["positive"] == positive, point["note"]
    assert point["inertia"]["zero"] == 0
    assert point["kind"] == ("saddle" if negative > 0 else "minimum"), point["note"]


@pytest.mark.parametrize("discretization", ["galerkin_gauss(s=4)", "galerkin_lobatto(s=3)"])
def test_on_a_resolving_grid_the_index_is_the_count_of_conjugate_points(discretization):
    for T in (2.0, 4.0, 10.0, 13.0):
        r = pardel.solve(OSCILLATOR_LAG, q0=[1.0], qN=[0.5], T=T, N=16, discretization=discretization)
        assert r.status == "converged", r.message
        assert r.point["inertia"]["negative"] == math.floor(T / math.pi), (T, r.point["note"])


def test_a_minimum_of_the_condensed_action_with_indefinite_interior_blocks_is_called_a_saddle():
    # x'' = -x over T = 10 on 3 intervals under galerkin_gauss(s=4): the node Hessian (the
    # condensed action's) is positive definite, each interval's interior block has one negative
    # eigenvalue, and the whole action's index is 3, as the continuous one (conjugate points at
    # pi, 2 pi, 3 pi). It was called a minimum.
    negative, _ = full_action_index("gauss", 4, 3, 10.0)
    assert negative == 3
    r = pardel.solve(OSCILLATOR_LAG, q0=[1.0], qN=[0.5], T=10.0, N=3, discretization="galerkin_gauss(s=4)")
    assert r.status == "converged", r.message
    assert r.point["kind"] == "saddle", r.point["note"]
    assert r.point["inertia"]["negative"] == 3
    assert "3 negative and 0 zero of them in the intervals' interior values" in r.point["note"]
    assert "the condensed action's, is positive definite" in r.point["note"]

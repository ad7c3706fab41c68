"""The condensed blocks of a Galerkin interval (D11, D12, D22: the Schur complements of the
interior values) carry the rounding of the node blocks alone. Written with interior values at
points, the elimination cancelled: the uncondensed node block of an order-3 model under
galerkin_gauss(s=5) was 87 times the condensed one (740 times at s=6), and D11 came out 1e-14 to
1e-13 off, relative, enough for Newton to stall on a linear order-3 saddle from N = 200 on.
Truth: the same condensation in 40-digit arithmetic (mpmath) over another basis of the same
polynomial space (monomials, interior values at equally spaced points): the discrete Lagrangian
does not depend on the basis."""
import math

import mpmath as mp
import numpy as np
import pytest

import pardel

mp.mp.dps = 40


def gauss(n):
    """The n-point Gauss-Legendre rule on [0, 1]."""
    nodes, weights = [], []
    for x0 in np.polynomial.legendre.leggauss(n)[0]:
        x = mp.findroot(lambda y: mp.legendre(n, y), mp.mpf(x0))
        nodes.append((x + 1) / 2)
        weights.append(1 / ((1 - x ** 2) * mp.diff(lambda y: mp.legendre(n, y), x) ** 2))
    return nodes, weights


def condensed_blocks(order, s, h, c):
    """D11, D12, D22 of L = x^(order)^2/2 + c x'^2/2 under galerkin_gauss(s): the action over the
    polynomial of degree s + order - 1 through both jets and s - order interior values, made
    stationary in the interior values."""
    h = mp.mpf(h)
    degree = s + order - 1
    m = s - order

    def row(u, d):  # d-th t-derivative at fraction u of each monomial u^k
        return [mp.mpf(0) if k < d else mp.factorial(k) / mp.factorial(k - d) * u ** (k - d) / h ** d
                for k in range(degree + 1)]

    rows = [row(mp.mpf(0), d) for d in range(order)]
    rows += [row(mp.mpf(j + 1) / (m + 1), 0) for j in range(m)]
    rows += [row(mp.mpf(1), d) for d in range(order)]
    to_coefficients = mp.matrix(rows) ** -1
    H = mp.zeros(degree + 1, degree + 1)
    for u, w in zip(*gauss(s)):
        top = mp.matrix([row(u, order)]) * to_coefficients
        one = mp.matrix([row(u, 1)]) * to_coefficients
        H += h * w * (top.T * top + c * one.T * one)
    a, z, b = list(range(order)), list(range(order, order + m)), list(range(order + m, 2 * order + m))

    def part(r, k):
        return mp.matrix([[H[i, j] for j in k] for i in r])

    inverse = part(z, z) ** -1 if m else None

    def schur(r, k):
        return part(r, k) - (part(r, z) * inverse * part(z, k) if m else 0)

    return [np.array(schur(r, k).tolist(), dtype=float) for r, k in ((a, a), (a, b), (b, b))]


@pytest.mark.parametrize("order,s", [(1, 4), (1, 8), (2, 5), (2, 8), (3, 5), (3, 6), (3, 8)])
def test_condensed_blocks_carry_the_rounding_of_the_node_blocks_alone(order, s):
    lag = ("model condensed_tension_%d\norder %d\ncoords x\nparam c = 1\nL = x%s^2/2 + c*x'^2/2\n"
           "discretizations galerkin_gauss(s=%d)\n" % (order, order, "'" * order, s))
    model = pardel.model(lag)
    c, worst = 3.5, 0.0
    for h in (0.25, 0.01, 0.002):
        q0 = [0.1 * (k + 1) for k in range(order)]
        q1 = [0.3 - 0.05 * k for k in range(order)]
        k = pardel.kernels(model, "galerkin_gauss(s=%d)" % s, h, 0.0, h, q0, q1, {"c": c})
        for name, exact in zip(("D11", "D12", "D22"), condensed_blocks(order, s, h, mp.mpf(c))):
            # each entry against the geometric mean of its row's and column's diagonal entries
            d = np.sqrt(np.abs(np.diag(exact)))
            scale = np.outer(d, d)
            worst = max(worst, float(np.max(np.abs(np.asarray(k[name]) - exact) / scale)))
    assert worst < 2e-15, worst


SADDLE_LAG = """\
model condensed_saddle_jerk
order 3
coords x
param c = 1
L = x'''^2/2 - c*x'^2/2 - x
discretizations galerkin_gauss(s=5) galerkin_lobatto(s=5)
"""


def saddle_motion(c, T, qa, qb):
    """x^(6) - c x'' = -1 with x, x', x'' given at 0 and T: t^2/(2c) plus 1, t, exp(k (t - T)),
    exp(-k t), cos k t, sin k t (k = c^(1/4)); the value at times t."""
    k = c ** 0.25

    def jet(t):
        rows = []
        for n in range(3):
            rows.append([1.0 if n == 0 else 0.0, t if n == 0 else (1.0 if n == 1 else 0.0),
                         k ** n * np.exp(k * (t - T)), (-k) ** n * np.exp(-k * t),
                         k ** n * np.cos(k * t + n * np.pi / 2), k ** n * np.sin(k * t + n * np.pi / 2)])
        return rows

    def particular(t):
        return [t * t / (2 * c), t / c, 1 / c]

    rhs = np.array(qa + qb) - np.array(particular(0.0) + particular(T))
    coef = np.linalg.solve(np.array(jet(0.0) + jet(T)), rhs)
    return lambda t: np.array([row[0] for row in (jet(ti) for ti in t)]) @ coef + t * t / (2 * c)


@pytest.mark.parametrize("discretization", ["galerkin_gauss(s=5)", "galerkin_lobatto(s=5)"])
def test_a_linear_order_three_saddle_converges_in_one_newton_iteration(discretization):
    # Index 2 (c between the second and third eigenvalues of the fourth-order operator on [0, 0.9]):
    # Newton on the DEL residual stalled from N = 100 on, 1e-7 to 1e-5 from the motion, where the
    # condensed blocks were 1e-14 off.
    c, T, qa, qb = 39828.7, 0.9, [0.0, 0.0, 0.0], [0.2, 0.0, 0.0]
    for N in (100, 200, 300):
        r = pardel.solve(SADDLE_LAG, q0=qa, qN=qb, T=T, N=N, discretization=discretization, params={"c": c},
                         method="stationary-newton")
        assert r.status == "converged", r.message
        assert r.point["kind"] == "saddle" and r.point["inertia"]["negative"] == 2, r.point
        assert r.iterations == 1, r.iterations
        exact = saddle_motion(c, T, qa, qb)(r.t)
        assert np.abs(r.q[:, 0] - exact).max() < 1e-13 * np.abs(exact).max()


def test_the_smallest_eigenvalue_of_a_convex_order_two_action_is_resolved_on_a_fine_grid():
    # L = x''^2/2 + 3 x'^2/2 - x on [0, 1.3]: the Hessian's smallest eigenvalue is (T/N) mu_1 with
    # mu_1 that of the continuous second variation, so N lambda_min is the same on every grid. The
    # condensed blocks' rounding put it 6e-4 low at N = 1000 (0.030329 against 0.030348).
    lag = ("model condensed_convex_beam\norder 2\ncoords x\nparam k = 3\nL = x''^2/2 + k*x'^2/2 - x\n"
           "discretizations galerkin_gauss(s=4)\n")
    scaled = []
    for N in (300, 1000):
        r = pardel.solve(lag, q0=[0, 0], qN=[0.5, 0], T=1.3, N=N, discretization="galerkin_gauss(s=4)")
        assert r.status == "converged" and r.point["kind"] == "minimum", r.message
        scaled.append(N * r.point["lambda_min"])
    assert abs(scaled[1] / scaled[0] - 1) < 5e-5, scaled


@pytest.mark.parametrize("order,s", [(2, 3), (2, 4), (2, 8), (2, 16), (3, 5), (3, 8)])
def test_nodes_at_zero_with_moving_jets_condense(order, s):
    # Both nodes at x = 0 with x' = 1: the interior coefficients are zero or nearly (the Hermite
    # interpolant is the minimiser of x^(order)^2), and a coordinate's size taken from its node
    # values and coefficients alone was round-off: the interior Newton never stopped, the kernels
    # were NaN and the solve ended non_finite. Exact: the polynomial of degree 2 order - 1 through
    # the jets.
    lag = ("model condensed_hop_%d\norder %d\ncoords x\nL = x%s^2/2\ndiscretizations galerkin_gauss(s=%d)\n"
           % (order, order, "'" * order, s))
    jet = [0.0, 1.0] + [0.0] * (order - 2)
    T, N = 2.0, 10
    degree = 2 * order - 1

    def rows(t):
        return [[math.factorial(k) / math.factorial(k - d) * t ** (k - d) if k >= d else 0.0 for k in range(degree + 1)]
                for d in range(order)]

    coef = np.linalg.solve(np.array(rows(0.0) + rows(T)), jet + jet)
    k = pardel.kernels(pardel.model(lag), "galerkin_gauss(s=%d)" % s, 0.2, 0.0, 0.2, jet, jet)
    assert np.isfinite(k["Ld"]) and np.all(np.isfinite(k["D11"])), k
    r = pardel.solve(lag, q0=jet, qN=jet, T=T, N=N, discretization="galerkin_gauss(s=%d)" % s)
    assert r.status == "converged", r.message
    assert np.abs(r.q[:, 0] - np.polynomial.polynomial.polyval(r.t, coef)).max() < 1e-12

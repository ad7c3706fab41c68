"""A minimum whose lowest mode is repeated: the ratio of the two smallest eigenvalues, which marks a
nearly degenerate minimum, is 1 there, so the assessment compares the second with the third. The
isotropic oscillator q'' = -q in the plane reaches -q0 from every start at t = pi: both eigenvalues
of the lowest mode vanish together as T approaches pi, while the third stays away; in the line the
lone one is flagged against the next. The eigenvalues are checked against NumPy's of the discrete
Hessian assembled from the model's own interval kernels (pardel.kernels), and for the trapezoid
against the exact ones, (4/h) sin^2(k pi / 2N) - h, each twice."""
import math

import numpy as np
import pytest

import pardel

PLANE_LAG = """\
model isotropic_plane
coords a b
L = (a'^2 + b'^2)/2 - (a^2 + b^2)/2
discretizations trapezoid galerkin_gauss(s=2)
"""

LINE_LAG = """\
model isotropic_line
coords a
L = a'^2/2 - a^2/2
discretizations trapezoid galerkin_gauss(s=2)
"""

CASES = [("galerkin_gauss(s=2)", 32), ("trapezoid", 256)]


def assembled_hessian(model, discretization, T, N, q):
    """The Hessian of the discrete action over the N - 1 interior nodes at the trajectory q (the
    end nodes fixed): the blocks D11, D12, D22 of each interval's discrete Lagrangian, summed."""
    d = q.shape[1]
    h = T / N
    H = np.zeros(((N - 1) * d, (N - 1) * d))
    for k in range(N):
        K = pardel.kernels(model, discretization, h, k * h, (k + 1) * h, q[k], q[k + 1])
        D11, D12, D22 = (np.array(K[name], dtype=float).reshape(d, d) for name in ("D11", "D12", "D22"))
        left, right = slice((k - 1) * d, k * d), slice(k * d, (k + 1) * d)  # nodes k and k + 1
        if k >= 1:
            H[left, left] += D11
        if k <= N - 2:
            H[right, right] += D22
        if 1 <= k <= N - 2:
            H[left, right] += D12
            H[right, left] += D12.T
    return H


def plane(discretization, N, T):
    """The plane oscillator solved, with NumPy's eigenvalues of its assembled Hessian."""
    m = pardel.model(PLANE_LAG)
    r = pardel.solve(m, q0=[1.0, 0.3], qN=[-0.9, -0.2], T=T, N=N, discretization=discretization)
    assert r.status == "converged", r.message
    H = assembled_hessian(m, discretization, T, N, r.q)
    np.testing.assert_allclose(H, H.T, rtol=0, atol=1e-12 * np.abs(H).max())
    e = np.linalg.eigvalsh(H)
    if discretization == "trapezoid":  # two copies of tridiag(-1/h, 2/h - h, -1/h)
        h = T / N
        exact = np.sort([4 / h * math.sin(k * math.pi / (2 * N)) ** 2 - h for k in range(1, N) for _ in range(2)])
        np.testing.assert_allclose(e[:6], exact[:6], rtol=0, atol=1e-12 * exact[-1])
    return r, e


@pytest.mark.parametrize("discretization,N", CASES)
def test_a_two_fold_soft_mode_far_below_the_third_is_nearly_degenerate(discretization, N):
    T = math.pi - 1e-4
    line = pardel.solve(LINE_LAG, q0=[1.0], qN=[-0.9], T=T, N=N, discretization=discretization)
    assert line.status == "converged", line.message
    assert line.point["kind"] == "minimum" and line.point["nearly_degenerate"]
    r, e = plane(discretization, N, T)
    p = r.point
    # The truth: a two-fold smallest eigenvalue far below the third (a ratio 1.7e-5 for the
    # trapezoid, 2.1e-5 for Galerkin), positive.
    assert 0 < e[0] and e[1] - e[0] <= 1e-6 * e[1]
    assert e[1] < 1e-4 * e[2] and e[3] - e[2] <= 1e-6 * e[3]
    assert p["kind"] == "minimum" and p["lambda_settled"]
    # Ritz values: upper bounds, the smallest within 1e-4, the next within 3e-3 (below by no more
    # than the round-off of a Hessian whose smallest eigenvalue is 2e-9 of its largest: 1e-5).
    assert e[0] * (1 - 1e-5) <= p["lambda_min"] <= e[0] * (1 + 1e-4)
    assert e[1] * (1 - 1e-5) <= p["lambda_next"] <= e[1] * (1 + 3e-3)
    assert abs(p["lambda_min"] - line.point["lambda_min"]) <= 0.05 * line.point["lambda_min"]
    assert p["nearly_degenerate"], p["note"]
    assert p["soft_motion"] == pytest.approx(math.sqrt(2e-16 * abs(r.action) / p["lambda_min"]), rel=1e-9)
    assert p["note"].startswith("a nearly degenerate minimum whose lowest mode is two-fold"), p["note"]
    assert "in a two-dimensional subspace" in p["note"], p["note"]
    # The third eigenvalue, as the note gives it (3 significant digits), is NumPy's.
    third = float(p["note"].split("of the third (")[1].split(")")[0])
    assert third == pytest.approx(e[2], rel=5e-3)
    assert "nearly equal" not in line.point["note"]
    assert "two-fold" not in line.point["note"]


@pytest.mark.parametrize("discretization,N", CASES)
@pytest.mark.parametrize("T", [1.0, math.pi - 0.02, math.pi - 1e-3])
def test_a_two_fold_mode_not_far_below_the_third_is_not_nearly_degenerate(discretization, N, T):
    # The same two-fold lowest mode, but with the third eigenvalue at most 5e3 times above it
    # (T = pi - 1e-3: 2.1e-4 of it, next to the threshold 1e-4).
    r, e = plane(discretization, N, T)
    p = r.point
    assert 0 < e[0] and e[1] - e[0] <= 1e-6 * e[1]
    assert e[1] >= 1e-4 * e[2] and e[2] > 2 * e[1]
    assert p["kind"] == "minimum" and p["lambda_settled"]
    assert e[0] * (1 - 1e-5) <= p["lambda_min"] <= e[0] * (1 + 1e-4)
    assert e[1] * (1 - 1e-5) <= p["lambda_next"] <= e[1] * (1 + 3e-3)
    assert p["lambda_next"] < 2 * p["lambda_min"]
    assert not p["nearly_degenerate"], p["note"]
    assert p["soft_motion"] == 0
    assert "the two smallest eigenvalues lie within a factor 2 of each other (as a two-fold lowest mode makes them)" in p["note"], p["note"]
    third = float(p["note"].split("and the third, ")[1].split(",")[0])
    assert third == pytest.approx(e[2], rel=5e-3)

"""The error estimate of pardel.solve (Result.error_estimate, error_by_coordinate, error_note,
extrapolated): on a model written here (two repelling springs, x'' = k^2 x and y'' = 4 k^2 y,
exact solutions in cosh and sinh) it lies within a factor 3 of the true node error; it is NaN with
the reason when switched off or when the solve did not converge; extrapolate=True returns a far
more accurate path; the arguments are bools."""
import math

import numpy as np
import pytest

import pardel

REPELLER_LAG = """\
# two repelling springs: x'' = k^2 x, y'' = 4 k^2 y
model repeller_pair
coords x y
param k = 1.3
L = 1/2*(x'^2 + y'^2) + 1/2*k^2*(x^2 + 4*y^2)
discretizations trapezoid midpoint
"""
K, T0, T = 1.3, 0.5, 1.7


def exact(t):
    """x = cosh(k t) - 0.6 sinh(k t), y = 0.3 cosh(2 k t) + 0.1 sinh(2 k t)."""
    return np.stack([np.cosh(K * t) - 0.6 * np.sinh(K * t), 0.3 * np.cosh(2 * K * t) + 0.1 * np.sinh(2 * K * t)], axis=1)


def solve(N, **options):
    ends = exact(np.array([T0, T0 + T]))
    return pardel.solve(REPELLER_LAG, q0=ends[0], qN=ends[1], T=T, N=N, t0=T0, rtol=1e-13, **options)


@pytest.mark.parametrize("discretization", ["trapezoid", "midpoint"])
def test_the_estimate_is_within_a_factor_3_of_the_true_error(discretization):
    for N in (16, 40, 100):
        r = solve(N, discretization=discretization)
        assert r.status == "converged", r.message
        error = np.abs(r.q - exact(r.t))
        assert error.max() / 3 < r.error_estimate < 3 * error.max(), (N, r.error_estimate, error.max())
        assert set(r.error_by_coordinate) == {"x", "y"}
        for i, name in enumerate(("x", "y")):
            assert error[:, i].max() / 3 < r.error_by_coordinate[name] < 3 * error[:, i].max()
        assert r.error_estimate == max(r.error_by_coordinate.values())
        assert r.summary["error_estimate"] == r.error_estimate
        assert r.summary["error"]["coarse_N"] == N // 2
        assert "every other node" in r.error_note
        assert not r.extrapolated


def test_extrapolated_path_is_far_more_accurate():
    raw = solve(40)
    extrapolated = solve(40, extrapolate=True)
    assert extrapolated.extrapolated and extrapolated.summary["error"]["extrapolated"]
    raw_error = np.abs(raw.q - exact(raw.t)).max()
    extrapolated_error = np.abs(extrapolated.q - exact(extrapolated.t)).max()
    assert extrapolated_error * 30 < raw_error, (raw_error, extrapolated_error)
    assert extrapolated.residual == raw.residual  # the summary describes the discrete solution


def test_switched_off_and_not_converged_are_not_estimated():
    off = solve(40, error_estimate=False)
    assert off.status == "converged"
    assert math.isnan(off.error_estimate)
    assert off.summary["error_estimate"] is None
    assert off.error_by_coordinate == {}
    assert off.error_note == "not estimated: switched off (error_estimate = false)"
    stopped = solve(40, method="jacobi-newton", max_iterations=2)
    assert stopped.status == "max_iterations"
    assert math.isnan(stopped.error_estimate)
    assert stopped.error_note == "not estimated: the solve ended max_iterations"


@pytest.mark.parametrize("name", ["error_estimate", "extrapolate"])
def test_the_switches_are_bools(name):
    with pytest.raises(TypeError, match=r"^pardel\.solve: %s must be True or False, got int 1$" % name):
        solve(20, **{name: 1})
    with pytest.raises(pardel.PardelError, match=r"solver\.extrapolate = true needs the error estimate"):
        solve(20, error_estimate=False, extrapolate=True)

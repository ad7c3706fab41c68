"""The error estimate of pardel.solve (Result.error_estimate, error_by_coordinate, error_note,
extrapolated, solve_error): on a model written here (two repelling springs, x'' = k^2 x and y'' = 4 k^2 y,
exact solutions in cosh and sinh) it lies within a factor 3 of the true node error; it is NaN with
the reason when switched off or when the solve did not converge; extrapolate=True returns a far
more accurate path; the arguments are bools; the solve's own error (the Newton correction at the
answer) is in the estimate and in an adaptive solve's decision (the Gelfand problem, exact)."""
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


GELFAND_LAG = """\
# the Gelfand problem u'' = -2 exp(u), u(0) = u(1) = 0
model gelfand_probe
coords u
param lam = 2
L = 1/2*u'^2 - lam*exp(u)
discretizations galerkin_gauss(s=3)
"""


def gelfand_exact(t):
    """u = -2 log(cosh((t - 1/2) theta / 2) / cosh(theta / 4)), theta = 2 cosh(theta / 4) (the
    smaller root: the lower solution)."""
    theta = 1.0
    for _ in range(50):
        theta -= (theta - 2 * math.cosh(theta / 4)) / (1 - 0.5 * math.sinh(theta / 4))
    return -2 * np.log(np.cosh((t - 0.5) * theta / 2) / math.cosh(theta / 4))


def test_the_solves_own_error_is_in_the_estimate():
    # At N = 16 and the default rtol the tolerance leaves the iterate further from the motion than
    # the discretization does (order 6): the estimate includes the Newton correction at the answer.
    r = pardel.solve(GELFAND_LAG, q0=[0], qN=[0], T=1, N=16, discretization="galerkin_gauss(s=3)")
    assert r.status == "converged", r.message
    error = np.abs(r.q[:, 0] - gelfand_exact(r.t)).max()
    assert r.solve_error == r.summary["error"]["solve"]
    assert 0 < r.solve_error < r.error_estimate
    assert error / 3 < r.error_estimate < 3 * error, (r.error_estimate, error, r.solve_error)
    assert "with the solve's own error" in r.error_note
    # An adaptive solve for 1e-10 ends with the true error within the factor 3 a confirmed estimate
    # allows (before, it took this grid's estimate without the solve's error, 2.8e-11 against a true
    # error of 1.6e-10).
    a = pardel.solve(GELFAND_LAG, q0=[0], qN=[0], T=1, accuracy=1e-10, discretization="galerkin_gauss(s=3)")
    assert "reached" in a.grid_note and "not reached" not in a.grid_note, a.grid_note
    assert np.abs(a.q[:, 0] - gelfand_exact(a.t)).max() < 3e-10, a.grid_note


def test_an_unreachable_accuracy_returns_the_best_grid():
    # 1e-15 is below what double precision resolves here: the grids go on while the estimate falls,
    # and the one with the smallest estimate is returned (its error at round-off), not the last.
    a = pardel.solve(GELFAND_LAG, q0=[0], qN=[0], T=1, accuracy=1e-15, discretization="galerkin_gauss(s=3)")
    assert "not reached: the estimate stopped falling" in a.grid_note, a.grid_note
    assert "the grid with the smallest estimate" in a.grid_note, a.grid_note
    assert a.N < a.grid_sizes[-1]
    assert np.abs(a.q[:, 0] - gelfand_exact(a.t)).max() < 1e-12


HALF_PLANE_LAG = """\
# geodesics of the hyperbolic half-plane, the arc length as the clock (the time is the length)
model half_plane_arc
coords x y
L = (x'^2 + y'^2)/(2*y^2)
clock = sqrt(x'^2 + y'^2)/y
cost travel_time = clock
discretizations midpoint galerkin_lobatto(s=3)
"""


def test_under_a_free_final_time_the_node_times_are_estimated_at_the_discretizations_order():
    # The geodesic x = tanh(sigma), y = sech(sigma), sigma from -1.5 to 2: hyperbolic length 3.5,
    # the exact travel time; the node time at s_k is the length so far, 3.5 s_k. The coordinates at
    # the nodes (uniform in the path parameter) and the node times (the clock integrated over each
    # interval by the discretization's quadrature) are of order 6, and each estimate holds. Before,
    # the times were the clock summed by the left rule: first order (travel time 6.2e-3 off at N =
    # 128) and not estimated.
    a, b = -1.5, 2.0

    def exact_path(s):
        sigma = a + (b - a) * np.asarray(s)
        return np.stack([np.tanh(sigma), 1 / np.cosh(sigma)], axis=1)

    travel_errors = []
    for N in (16, 32):
        s = np.arange(N + 1) / N
        r = pardel.solve(HALF_PLANE_LAG, q0=exact_path([0.0])[0], qN=exact_path([1.0])[0], T=1.0, N=N,
                         discretization="galerkin_lobatto(s=3)", clock="free_final_time")
        assert r.status == "converged", r.message
        true_error = np.abs(r.q - exact_path(s)).max()
        assert r.error_estimate / 3 <= true_error <= 3 * r.error_estimate
        time_error = np.abs(r.t - (b - a) * s).max()
        assert r.error_time_estimate / 3 <= time_error <= 3 * r.error_time_estimate, (time_error, r.error_note)
        assert "the node times (the clock integrated over each interval by the discretization's quadrature), " \
               "estimated alike" in r.error_note
        assert r.summary["error"]["time"] == r.error_time_estimate
        travel_errors.append(abs(r.cost - (b - a)))
    assert 2 ** 5.5 < travel_errors[0] / travel_errors[1] < 2 ** 6.5


def test_a_third_level_with_a_lone_interval_beside_a_knot_does_not_confirm():
    # x'' = -x on [0, 2] through a knot on the motion x = sin t at t = 0.5. At N = 16 the third level
    # (N = 4) has a single interval from 0 to the knot, too coarse for an order to show: the estimate
    # is not confirmed. At N = 32 (third level N = 8, two intervals there) it is, within a factor 3.
    knot = [(0.5, [math.sin(0.5)])]
    for N, confirmed in ((16, False), (32, True)):
        r = pardel.solve("harmonic", q0=[0], qN=[math.sin(2.0)], T=2.0, N=N, knots=knot,
                         discretization="galerkin_lobatto(s=2)")
        assert r.status == "converged", r.message
        assert r.error_reliable == confirmed, r.error_note
        if confirmed:
            true_error = np.abs(r.q[::2, 0] - np.sin(r.t[::2])).max()
            assert r.error_estimate / 3 <= true_error <= 3 * r.error_estimate
        else:
            assert "it has a single interval between t = 0 and t = 0.5" in r.error_note


FORCED_BEAM_LAG = """\
# order 2: x'''' + a x'' ... with the forcing made so that x = sin 2t + 0.3 t^2 is the motion
model forced_beam_estimate
order 2
coords x
param a = 3
let X = sin(2*t) + 3/10*t^2
L = 1/2*x''^2 + a/2*x'^2 + 1/4*x^4 - (16*sin(2*t) - a*(-4*sin(2*t) + 6/10) + X^3)*x
discretizations trapezoid(alpha=1) gauss2
"""


@pytest.mark.parametrize("discretization", ["trapezoid(alpha=1)", "gauss2"])
def test_grid_levels_that_were_not_refined_do_not_enter_the_estimate(discretization):
    # An order-2 model at N = 2000: iterative refinement corrects the final level of auto's nested
    # iteration, not its coarser levels, whose round-off (eps N^4) made the estimate 4.1e-6 against
    # a true 3.4e-14 under gauss2 (observed order 0.69), and the extrapolated path that far off;
    # under trapezoid(alpha=1) a confirmed estimate 7 times the error and an extrapolated path 4
    # times worse than the discrete one. Exact motion x = sin 2t + 0.3 t^2 on [0.3, 2.5].
    def jet(t):
        return [math.sin(2 * t) + 0.3 * t * t, 2 * math.cos(2 * t) + 0.6 * t]

    common = dict(q0=jet(0.3), qN=jet(2.5), T=2.2, t0=0.3, N=2000, discretization=discretization)
    plain = pardel.solve(FORCED_BEAM_LAG, **common)
    assert plain.converged and plain.refinement_steps >= 1, plain.refinement_note
    exact = np.sin(2 * plain.t) + 0.3 * plain.t ** 2
    true_error = np.abs(plain.q[:, 0] - exact).max()
    assert true_error / 3 <= plain.error_estimate <= 3 * max(true_error, 1e-13), (plain.error_estimate, true_error)
    extrapolated = pardel.solve(FORCED_BEAM_LAG, extrapolate=True, **common)
    if extrapolated.extrapolated:
        assert np.abs(extrapolated.q[:, 0] - exact).max() <= max(true_error, 1e-14)
    else:
        assert "not extrapolated: the estimate is not confirmed" in extrapolated.error_note


SLOW_AND_FAST_LAG = """\
# u'' = -u/4 and v'' = -w^2 v, uncoupled: one coordinate resolved long before the other
model slow_and_fast
coords u v
param w = 14
L = u'^2/2 - u^2/8 + v'^2/2 - w^2*v^2/2
discretizations trapezoid galerkin_gauss(s=2)
"""


def slow_and_fast_exact(t, w=14.0):
    return np.stack([20 * np.sin(t / 2 + 0.3), 1e-3 * np.cos(w * t - 0.2)], axis=-1)


@pytest.mark.parametrize("discretization,N", [("trapezoid", 16), ("trapezoid", 24), ("galerkin_gauss(s=2)", 12)])
def test_a_resolved_coordinate_does_not_confirm_the_estimate_of_an_unresolved_one(discretization, N):
    # Before, the order was checked on the largest differences over the coordinates: u's (order 2)
    # confirmed the estimate while v, pre-asymptotic on these grids, was off by 14 to 48 times its own.
    T = 2.5
    ends = slow_and_fast_exact(np.array([0.0, T]))
    r = pardel.solve(SLOW_AND_FAST_LAG, q0=ends[0], qN=ends[1], T=T, N=N, discretization=discretization)
    assert r.status == "converged", r.message
    truth = np.abs(r.q[:, :2] - slow_and_fast_exact(r.t)).max(axis=0)
    ratio_v = truth[1] / r.error_by_coordinate["v"]
    if r.error_reliable:
        assert 1 / 3 <= ratio_v <= 3, (r.error_note, truth, r.error_by_coordinate)
    else:
        assert "estimate unreliable" in r.error_note
    assert not (r.error_reliable and ratio_v > 3)


@pytest.mark.parametrize("w", [12.0, 14.0, 16.0])
def test_an_adaptive_request_is_met_by_every_coordinate(w):
    # Equal amplitudes over T = 3.5: u's differences confirmed order 2 on the first grids and the
    # request was "reached on N = 16" with v off by 8 to 14 times it.
    T = 3.5

    def exact(t):
        return np.stack([1e-3 * (np.cos(t / 2) + np.sin(t / 2)), 1e-3 * (np.cos(w * t) + np.sin(w * t))], axis=-1)

    ends = exact(np.array([0.0, T]))
    r = pardel.solve(SLOW_AND_FAST_LAG, q0=ends[0], qN=ends[1], T=T, accuracy=1e-4, discretization="trapezoid",
                     params={"w": w})
    assert r.status == "converged", r.message
    assert "reached" in r.grid_note and "not reached" not in r.grid_note, r.grid_note
    truth = np.abs(r.q[:, :2] - exact(r.t)).max()
    assert truth <= 3e-4, (truth, r.grid_note)
    assert truth / 3 <= r.error_estimate <= 3 * truth, (truth, r.error_estimate)

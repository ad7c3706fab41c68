"""The node times under the free_final_time clock: the clock integrated over each interval by the
discretization's own interpolant and quadrature (pardel_discretization::travel), so that the
travel time has the discretization's order; before, the seed's left rule made it first order
whatever the discretization. Checked against closed forms and scipy's quad on exact motions,
with a clock that the motion does not make stationary (its integral is not the action), and an
order-2 model; where L and the clock depend on t, each interval's end time is the fixed point of
its integral, at second order."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

import pardel

SPRING_LAG = """\
# x'' = -x in the path parameter s; the clock F = 1 + x^2 + x'^2/4 is not the action's integrand
model spring_with_clock
coords x
L = (x'^2 - x^2)/2
clock = 1 + x^2 + x'^2/4
cost travel_time = clock
discretizations trapezoid midpoint galerkin_gauss(s=2) galerkin_lobatto(s=3) galerkin_gauss(s=4)
"""

ROD_LAG = """\
# order 2: x'''' = 4 x'', x = a + b s + c cosh 2s + d sinh 2s; clock 1 + x'^2
model rod_with_clock
order 2
coords x
L = x''^2/2 + 2*x'^2
clock = 1 + x'^2
cost travel_time = clock
discretizations gauss2 hermite_gauss(s=3) galerkin_gauss(s=3)
"""

SLOWING_LAG = """\
# the speed falls with t in a medium the same everywhere: F = (1 + t/10)|q'|, L = F^2/2; the path
# is straight and the travel time T over a length l solves 10 ln(1 + T/10) = l
model slowing_medium
coords x y
let F = (1 + t/10)*sqrt(x'^2 + y'^2)
L = F^2/2
clock = F
cost travel_time = clock
discretizations trapezoid galerkin_gauss(s=2)
"""

S = 1.3


def spring_time(s):
    """The integral of 1 + sin^2 + cos^2/4 from 0 to s."""
    return 13 / 8 * s - 3 / 16 * np.sin(2 * s)


@pytest.mark.parametrize("discretization,order", [("trapezoid", 2), ("midpoint", 2), ("galerkin_gauss(s=2)", 4),
                                                  ("galerkin_lobatto(s=3)", 6)])
def test_node_times_converge_at_the_discretizations_order(discretization, order):
    errors = []
    for N in (8, 16):
        r = pardel.solve(SPRING_LAG, q0=[0.0], qN=[math.sin(S)], T=S, N=N, discretization=discretization,
                         clock="free_final_time")
        assert r.status == "converged", r.message
        s = np.arange(N + 1) / N * S
        errors.append(np.abs(r.t - spring_time(s)).max())
        assert abs(r.cost - spring_time(S)) <= errors[-1]
        assert "integrated over each interval by the discretization's quadrature" in r.cost_definition
        assert r.error_time_estimate / 3 <= errors[-1] <= 3 * r.error_time_estimate, (errors[-1], r.error_note)
    assert abs(math.log2(errors[0] / errors[1]) - order) < 0.2, errors


def test_interior_values_integrate_the_clock_to_round_off_on_a_coarse_grid():
    r = pardel.solve(SPRING_LAG, q0=[0.0], qN=[math.sin(S)], T=S, N=8, discretization="galerkin_gauss(s=4)",
                     clock="free_final_time")
    assert r.status == "converged", r.message
    assert np.abs(r.t - spring_time(np.arange(9) / 8 * S)).max() < 1e-12


def rod_exact(s):
    """x = a + b s + c cosh 2s + d sinh 2s through x(0) = 0, x'(0) = 1, x(1) = 1, x'(1) = 0."""
    def rows(u):
        return (np.array([1, u, np.cosh(2 * u), np.sinh(2 * u)]),
                np.array([0, 1, 2 * np.sinh(2 * u), 2 * np.cosh(2 * u)]))
    (b0, d0), (b1, d1) = rows(0.0), rows(1.0)
    coefficients = np.linalg.solve(np.array([b0, d0, b1, d1]), [0, 1, 1, 0])
    return lambda u: rows(u)[1] @ coefficients  # x'(u)


@pytest.mark.parametrize("discretization,order", [("gauss2", 4), ("hermite_gauss(s=3)", 4),
                                                  ("galerkin_gauss(s=3)", 6)])
def test_an_order_two_models_travel_time_has_the_discretizations_order(discretization, order):
    velocity = rod_exact(None)
    exact = quad(lambda u: 1 + velocity(u) ** 2, 0, 1, epsabs=1e-13, epsrel=1e-13, limit=200)[0]
    errors = []
    for N in (8, 16):
        r = pardel.solve(ROD_LAG, q0=[0, 1], qN=[1, 0], T=1.0, N=N, discretization=discretization,
                         clock="free_final_time")
        assert r.status == "converged", r.message
        errors.append(abs(r.cost - exact))
    assert errors[1] > 1e-11 and abs(math.log2(errors[0] / errors[1]) - order) < 0.3, errors


@pytest.mark.parametrize("discretization", ["trapezoid", "galerkin_gauss(s=2)"])
def test_a_time_dependent_clock_is_integrated_at_second_order(discretization):
    # Where L and the clock depend on t, the time at a quadrature point is linear between the
    # interval's node times (as in the discrete Lagrangian), and each interval's end time is found
    # by fixed-point iteration: second order whatever the discretization. The seed's left rule
    # was first order (8.65e-4 off at N = 64, now 2.3e-7).
    exact = 10 * (math.exp(0.1) - 1)  # l = 1
    errors = []
    for N in (16, 32):
        r = pardel.solve(SLOWING_LAG, q0=[0, 0], qN=[1, 0], T=1.0, N=N, discretization=discretization,
                         clock="free_final_time")
        assert r.status == "converged", r.message
        assert np.abs(r.q[:, 1]).max() < 1e-12  # the straight path
        errors.append(abs(r.cost - exact))
        assert r.error_time_estimate / 3 <= errors[-1] <= 3 * r.error_time_estimate, (errors[-1], r.error_note)
        assert "integrated over each interval by the discretization's quadrature" in r.cost_definition
        # Each node time is its interval's fixed point: t_{k+1} = t_k + the clock integrated with t
        # linear from t_k to t_{k+1}; for trapezoid h/2 (F(t_k, v) + F(t_{k+1}, v)).
        if discretization == "trapezoid":
            h = 1.0 / N
            speed = np.hypot(np.diff(r.q[:, 0]), np.diff(r.q[:, 1])) / h
            step = h / 2 * ((1 + r.t[:-1] / 10) + (1 + r.t[1:] / 10)) * speed
            assert np.allclose(np.diff(r.t), step, rtol=1e-13, atol=0)
    assert abs(math.log2(errors[0] / errors[1]) - 2) < 0.1, errors


JERK_CLOCK_LAG = """\
# order 3: the sixth derivative of x is -16 x'', solved by 1, s and e^(rs) for r^4 = -16; clock 1 + x'^2
model jerk_with_clock
order 3
coords x
L = x'''^2/2 + 8*x'^2
clock = 1 + x'^2
cost travel_time = clock
discretizations hermite_gauss(s=3)
"""


def jerk_exact(s, T=2.0):
    """The motion through x, x', x'' = (0, 1, 0) at 0 and (1, 0, 0) at T: a combination of 1, s and
    the real and imaginary parts of e^(r s), r = sqrt(2) (1 + i) and sqrt(2) (-1 + i)."""
    roots = [math.sqrt(2) * (1 + 1j), math.sqrt(2) * (-1 + 1j)]

    def jets(u):
        rows = []
        for k in range(3):
            row = [1.0 if k == 0 else 0.0, u if k == 0 else (1.0 if k == 1 else 0.0)]
            for r in roots:
                v = r ** k * np.exp(r * u)
                row += [v.real, v.imag]
            rows.append(row)
        return np.array(rows)
    coefficients = np.linalg.solve(np.vstack([jets(0.0), jets(T)]), [0, 1, 0, 1, 0, 0])
    return np.array([jets(u)[0] @ coefficients for u in np.atleast_1d(s)])


@pytest.mark.parametrize("N", [200, 1000])
def test_free_final_time_of_a_model_without_t_is_refined_and_assessed_as_without_a_clock(N):
    # The node times only report the travel time here (L and the clock do not depend on t), so the
    # discrete problem is the one without a clock mode. Under free_final_time it was solved without
    # iterative refinement and assessed in double: an order-3 model's nodes drifted from the motion
    # with N (5.3e-7 at N = 64, an order-4 model 0.026 at N = 1000, each "converged").
    free = pardel.solve(JERK_CLOCK_LAG, q0=[0, 1, 0], qN=[1, 0, 0], T=2.0, N=N, clock="free_final_time")
    plain = pardel.solve(JERK_CLOCK_LAG, q0=[0, 1, 0], qN=[1, 0, 0], T=2.0, N=N)
    assert free.status == "converged" and plain.status == "converged", free.message
    s = np.arange(N + 1) * 2.0 / N
    assert np.abs(free.q[:, 0] - jerk_exact(s)).max() < 1e-11
    assert np.abs(free.q - plain.q).max() < 1e-13
    assert free.point["kind"] == "minimum" and free.point["lambda_min"] == pytest.approx(plain.point["lambda_min"])
    assert free.refinement_steps == plain.refinement_steps
    assert free.cost == pytest.approx(plain.cost, rel=1e-14)  # t_N and the summed clock


def test_the_node_times_estimate_is_at_least_their_round_off_and_holds_the_solves_share():
    # dt/ds = 1: every grid's node times are the path parameter itself, so two grids agree to the
    # rounding of the sums; the estimate is then that rounding, 8 eps max|t|, not the difference.
    lag = "model unit_clock\ncoords x\nL = x'^2/2 + x^2/2\nclock = 1 + 0*x'\ndiscretizations trapezoid\n"
    r = pardel.solve(lag, q0=[0.0], qN=[1.0], T=2.5, N=32, clock="free_final_time")
    assert r.status == "converged", r.message
    assert np.abs(r.t - np.arange(33) * 2.5 / 32).max() < 1e-14
    floor = 8 * np.finfo(float).eps * 2.5
    assert floor <= r.error_time_estimate < 10 * floor, r.error_time_estimate
    assert "the node times' estimate with the solve's own error in them" in r.error_note, r.error_note


def test_a_clock_undefined_on_the_path_names_its_interval():
    # Without a clock mode the clock only gives the cost; where it is not a number on the path the
    # cost is null and its definition says where (the solve of L is not affected).
    lag = "model root_clock\ncoords x\nL = x'^2/2\nclock = sqrt(x - 1/2)\ncost travel_time = clock\n" \
          "discretizations trapezoid\n"
    r = pardel.solve(lag, q0=[0.0], qN=[1.0], T=1.0, N=10)
    assert r.status == "converged", r.message
    assert r.cost is None
    assert "not finite: the clock's share of interval 0 (t = 0 to 0.1) is not a number" in r.cost_definition

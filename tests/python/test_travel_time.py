"""The node times under the free_final_time clock: the clock integrated over each interval by the
discretization's own interpolant and quadrature (pardel_discretization::travel), so that the
travel time has the discretization's order; before, the seed's left rule made it first order
whatever the discretization. Checked against closed forms and scipy's quad on exact motions,
with a clock that the motion does not make stationary (its integral is not the action), and an
order-2 model; a model whose L depends on t keeps the left rule, which places the node times at
which L is evaluated (part of its discrete problem), and says so."""
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

DRIFT_LAG = """\
# L depends on t: the node times enter the discrete problem, placed by the left rule
model drift_with_clock
coords x
L = x'^2/2 + t*x/10
clock = 1 + x'^2/4
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


def test_a_time_dependent_model_keeps_the_left_rule_and_says_so():
    r = pardel.solve(DRIFT_LAG, q0=[0.0], qN=[1.0], T=1.0, N=16, discretization="galerkin_gauss(s=2)",
                     clock="free_final_time")
    assert r.status == "converged", r.message
    assert "left rule" in r.cost_definition
    assert math.isnan(r.error_time_estimate) and r.summary["error"]["time"] is None
    assert "the clock summed by a left rule" in r.error_note
    # The left rule itself: t_{k+1} = t_k + h F(q_k, (q_{k+1} - q_k)/h).
    h = 1.0 / 16
    v = np.diff(r.q[:, 0]) / h
    assert np.allclose(np.diff(r.t), h * (1 + v ** 2 / 4), rtol=1e-13, atol=0)

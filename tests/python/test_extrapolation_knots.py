"""The extrapolated path beside a knot: the correction's slope jumps at the knot, so the
corrections at the nodes between common ones are interpolated within each stretch between the
ends and the knots. Across the knot they lost an order next to it (trapezoid: order 3 there
against 4 at the common nodes). Checked on x'' = 4x with a knot off the smooth curve, whose exact
solution is A e^(2t) + B e^(-2t) on each stretch."""
import math

import numpy as np
import pytest

import pardel

LAG = """\
model knotted_growth
coords x
L = x'^2/2 + 2*x^2
discretizations trapezoid galerkin_gauss(s=2)
"""

T, KNOT = 2.0, 0.75
ENDS = (0.4, -0.3)
KNOT_VALUE = 1.3


def piece(t, ta, xa, tb, xb):
    # x = A e^(2t) + B e^(-2t) through (ta, xa) and (tb, xb)
    M = np.array([[math.exp(2 * ta), math.exp(-2 * ta)], [math.exp(2 * tb), math.exp(-2 * tb)]])
    A, B = np.linalg.solve(M, [xa, xb])
    return A * np.exp(2 * t) + B * np.exp(-2 * t)


def exact(t):
    t = np.asarray(t)
    return np.where(t <= KNOT, piece(t, 0.0, ENDS[0], KNOT, KNOT_VALUE), piece(t, KNOT, KNOT_VALUE, T, ENDS[1]))


@pytest.mark.parametrize("discretization,order", [("trapezoid", 4), ("galerkin_gauss(s=2)", 6)])
def test_the_extrapolated_path_keeps_its_order_beside_a_knot(discretization, order):
    errors = []
    for N in (32, 64, 128):
        r = pardel.solve(LAG, q0=[ENDS[0]], qN=[ENDS[1]], T=T, N=N, discretization=discretization,
                         knots=[(KNOT, [KNOT_VALUE])], extrapolate=True)
        assert r.status == "converged" and r.extrapolated, (r.message, r.error_note)
        e = np.abs(r.q[:, 0] - exact(r.t))
        errors.append((e[0::2].max(), e[1::2].max()))  # common nodes, the others
    for (c0, o0), (c1, o1) in zip(errors, errors[1:]):
        assert math.log2(o0 / o1) >= order - 0.4, errors
        assert o1 <= 3 * c1, errors  # the nodes between common ones are no worse than the common ones

"""The Galerkin family on fine grids for models of order 2 and 3, whose Hessians' condition grows
like N^(2 order): iterative refinement in extended precision (the condensed interval in pd_quad)
carries the solves to the rounding of the nodes, against exact motions written here. Before it,
the order-3 model's node error grew to 4.4e-3 at N = 256, and the order-2 model stalled from
N = 20 under s = 6 and s = 8."""
import math

import numpy as np
import pytest

import pardel

BEAM_LAG = """\
# L = x''^2/2 + c x'^2/2: x'''' = c x''
model stiff_beam_fine
order 2
coords x
param c = 4
L = x''^2/2 + c*x'^2/2
discretizations galerkin_gauss(s=6) galerkin_gauss(s=8) galerkin_lobatto(s=4)
"""

SEXTIC_LAG = """\
# L = x'''^2/2 + 20.16 t^2 x: x'''''' = 20.16 t^2, x = t^8/1000 - t^3 with the right end jets
model sextic_forcing_fine
order 3
coords x
L = 1/2*x'''^2 + 504/25*t^2*x
discretizations galerkin_gauss(s=4) galerkin_lobatto(s=4)
"""


def beam_exact(t):
    """x = a + b t + e cosh 2t + f sinh 2t with x(0) = 0, x'(0) = 1, x(1) = 1, x'(1) = 0."""
    basis = lambda s: np.array([np.ones_like(s), s, np.cosh(2 * s), np.sinh(2 * s)])
    dbasis = lambda s: np.array([np.zeros_like(s), np.ones_like(s), 2 * np.sinh(2 * s), 2 * np.cosh(2 * s)])
    M = np.array([basis(np.array(0.0)), dbasis(np.array(0.0)), basis(np.array(1.0)), dbasis(np.array(1.0))])
    return np.linalg.solve(M, [0, 1, 1, 0]) @ basis(t)


@pytest.mark.parametrize("discretization,N", [("galerkin_lobatto(s=4)", 640), ("galerkin_gauss(s=6)", 640),
                                              ("galerkin_gauss(s=8)", 160), ("galerkin_gauss(s=8)", 640)])
def test_galerkin_at_order_two_is_accurate_on_fine_grids(discretization, N):
    r = pardel.solve(BEAM_LAG, q0=[0, 1], qN=[1, 0], T=1.0, N=N, discretization=discretization)
    assert r.status == "converged" and r.point["kind"] == "minimum", r.message
    error = np.abs(r.q[:, 0] - beam_exact(r.t)).max()
    assert error < 1e-13, error
    assert r.error_estimate < 1e-12


@pytest.mark.parametrize("discretization", ["galerkin_gauss(s=4)", "galerkin_lobatto(s=4)"])
def test_galerkin_at_order_three_is_accurate_on_fine_grids(discretization):
    def jet(t):
        return [t ** 8 / 1000 - t ** 3, 8 * t ** 7 / 1000 - 3 * t ** 2, 56 * t ** 6 / 1000 - 6 * t]

    for N in (64, 256):
        r = pardel.solve(SEXTIC_LAG, q0=jet(0.5), qN=jet(2.5), T=2.0, t0=0.5, N=N, discretization=discretization)
        assert r.status == "converged", r.message
        x = r.q[:, 0]
        error = np.abs(x - (r.t ** 8 / 1000 - r.t ** 3)).max()
        assert error < 1e-12, (N, error)


def test_iterative_refinement_keyword_turns_the_refinement_off_and_on():
    """iterative_refinement="off" leaves the double solve's round-off (the order-3 model's node
    error was 4.4e-3 at N = 256 before the extended kernels); the default refines it away and says
    so in refinement_steps and refinement_note (summary.json's "refinement")."""
    def exact(t):
        return t ** 8 / 1000 - t ** 3

    jet0 = [0.5 ** 8 / 1000 - 0.5 ** 3, 8 * 0.5 ** 7 / 1000 - 3 * 0.5 ** 2, 56 * 0.5 ** 6 / 1000 - 3]
    jet1 = [2.5 ** 8 / 1000 - 2.5 ** 3, 8 * 2.5 ** 7 / 1000 - 3 * 2.5 ** 2, 56 * 2.5 ** 6 / 1000 - 15]
    common = dict(q0=jet0, qN=jet1, T=2.0, t0=0.5, N=256, discretization="galerkin_gauss(s=4)")
    refined = pardel.solve(SEXTIC_LAG, **common)
    plain = pardel.solve(SEXTIC_LAG, iterative_refinement="off", **common)
    assert refined.refinement_steps >= 1 and "correction" in refined.refinement_note, refined.refinement_note
    assert refined.summary["refinement"]["steps"] == refined.refinement_steps
    assert np.abs(refined.q[:, 0] - exact(refined.t)).max() < 1e-12
    assert plain.refinement_steps == 0 and plain.refinement_note == ""
    assert np.abs(plain.q[:, 0] - exact(plain.t)).max() > 1e-9
    with pytest.raises(pardel.PardelError, match="iterative_refinement"):
        pardel.solve(SEXTIC_LAG, iterative_refinement="sometimes", **common)


SNAP_LAG = """\
# order 4: x'''''''' + x^3 = X^3 + sin t, so that x = X = sin t + t^4/10
model forced_snap_fine
order 4
coords x
let X = sin(t) + 1/10*t^4
L = 1/2*x''''^2 + 1/4*x^4 - (X^3 + sin(t))*x
discretizations galerkin_gauss(s=5)
"""


def test_an_order_four_model_under_auto_passes_a_level_stalled_at_round_off():
    # auto's nested iteration at N = 1000 solves the levels 250 and 1000: Newton stalled at the
    # round-off level on the level N = 250 (condition ~N^8), and the solve stopped there, returning
    # that level interpolated, 6.2e-2 from the motion. A level below the last that stalls at its
    # round-off level is solved as well as double precision allows; the next one starts from it.
    def jet(t):
        return [math.sin(t) + 0.1 * t ** 4, math.cos(t) + 0.4 * t ** 3, -math.sin(t) + 1.2 * t * t,
                -math.cos(t) + 2.4 * t]

    r = pardel.solve(SNAP_LAG, q0=jet(0.3), qN=jet(2.5), T=2.2, t0=0.3, N=1000, discretization="galerkin_gauss(s=5)")
    assert r.status == "converged", r.message
    assert list(np.unique(r.history["N"])) == [250, 1000]
    assert np.abs(r.q[:, 0] - (np.sin(r.t) + 0.1 * r.t ** 4)).max() < 1e-9

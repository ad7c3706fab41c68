"""A coordinate whose Lagrangian is 1e-15 of another's: its DEL terms lie below the rounding of the
other's, so neither the action nor the residual's infinity norm shows its steps, and Newton stalled
at once with "the tolerance cannot be reached in double precision" while that coordinate was
unsolved. Each component's residual is now judged against its own round-off level: the stall says
which component is unsolved, and the automatic method goes on to Jacobi-Newton, whose node steps
are in each coordinate's own units. The truth: the same model at weight 1 (the DEL equations of
the decoupled y scale with the weight, so the discrete solution is the same) and the exact motion."""
import numpy as np
import pytest

import pardel

LAG = """\
# x'' = x/4 and y'' = -4 y, uncoupled, y's Lagrangian weighted by eps
model weighted_pair
coords x y
param eps = 1
L = x'^2/2 + x^2/8 + eps*(y'^2/2 - 2*y^2)
discretizations trapezoid galerkin_gauss(s=2)
"""

T = 2.0


def exact(t):
    # x = cosh(t/2), y = 0.3 cos 2t + 0.8 sin 2t
    return np.stack([np.cosh(t / 2), 0.3 * np.cos(2 * t) + 0.8 * np.sin(2 * t)], axis=-1)


@pytest.mark.parametrize("discretization", ["trapezoid", "galerkin_gauss(s=2)"])
def test_a_coordinate_weighted_1e_15_is_solved(discretization):
    ends = exact(np.array([0.0, T]))
    weighted = pardel.solve(LAG, q0=ends[0], qN=ends[1], T=T, N=64, discretization=discretization,
                            params={"eps": 1e-15})
    plain = pardel.solve(LAG, q0=ends[0], qN=ends[1], T=T, N=64, discretization=discretization)
    assert plain.status == "converged", plain.message
    assert weighted.status == "converged", weighted.message
    assert np.abs(weighted.q[:, 1] - plain.q[:, 1]).max() <= 1e-9
    assert np.abs(weighted.q[:, 0] - plain.q[:, 0]).max() <= 1e-12
    truth = np.abs(weighted.q[:, :2] - exact(weighted.t)).max()
    assert truth <= 3 * plain.error_estimate, (truth, plain.error_estimate)


def test_newton_alone_says_which_component_it_left_unsolved():
    ends = exact(np.array([0.0, T]))
    r = pardel.solve(LAG, q0=ends[0], qN=ends[1], T=T, N=64, discretization="trapezoid", params={"eps": 1e-15},
                     method="newton")
    if r.status == "converged":  # a step that the action could not judge may still have been taken
        assert np.abs(r.q[:, :2] - exact(r.t)).max() < 1e-2
    else:
        assert r.status == "stalled"
        assert "far above that of component y" in r.message, r.message
        assert "cannot be reached in double precision" not in r.message


GLIDE_LAG = """\
# a free particle x beside a spring y (y'' = -y over T = 2, below its conjugate time pi)
model glide_and_spring
coords x y
L = x'^2/2 + y'^2/2 - y^2/2
discretizations galerkin_gauss(s=2)
"""


@pytest.mark.parametrize("method", ["jacobi", "jacobi-newton"])
def test_the_jacobi_methods_count_the_rounding_of_large_values_in_their_tolerance(method):
    # x offset to 1e8: the rounding of the nodes seen through the Hessian, 2 eps |H||q|, lies far
    # above rtol times the DEL terms under galerkin_gauss(s=2). The Jacobi sweeps left that term out
    # of their round-off level and ran to max_iterations with the residual flat at 5e-7, on an
    # answer equal to the unshifted problem's.
    q0, qN = np.array([0.0, 0.4]), np.array([1.0, -0.7])
    shift = np.array([1e8, 0.0])
    r = pardel.solve(GLIDE_LAG, q0=q0 + shift, qN=qN + shift, T=T, N=16, method=method, max_iterations=5000)
    plain = pardel.solve(GLIDE_LAG, q0=q0, qN=qN, T=T, N=16, method=method, max_iterations=5000)
    assert plain.status == "converged", plain.message
    assert r.status == "converged", r.message
    assert r.iterations <= 1.2 * plain.iterations, (r.iterations, plain.iterations)
    assert np.abs(r.q[:, 1] - plain.q[:, 1]).max() <= 1e-7
    assert np.abs((r.q[:, 0] - 1e8) - plain.q[:, 0]).max() <= 1e-6

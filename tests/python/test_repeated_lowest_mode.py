"""A minimum whose lowest mode is repeated: the ratio of the two smallest eigenvalues, which marks a
nearly degenerate minimum, is 1 there, and the note says that it cannot tell. The isotropic
oscillator q'' = -q in the plane reaches -q0 from every start at t = pi: both eigenvalues of the
lowest mode vanish together as T approaches pi, while in the line the lone one is flagged."""
import math

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


@pytest.mark.parametrize("discretization,N", [("galerkin_gauss(s=2)", 32), ("trapezoid", 256)])
def test_a_repeated_soft_mode_is_not_passed_off_by_the_ratio(discretization, N):
    T = math.pi - 1e-4
    line = pardel.solve(LINE_LAG, q0=[1.0], qN=[-0.9], T=T, N=N, discretization=discretization)
    plane = pardel.solve(PLANE_LAG, q0=[1.0, 0.3], qN=[-0.9, -0.2], T=T, N=N, discretization=discretization)
    assert line.status == "converged" and plane.status == "converged", (line.message, plane.message)
    assert line.point["kind"] == "minimum" and line.point["nearly_degenerate"]
    p = plane.point
    assert p["kind"] == "minimum"
    # The same soft eigenvalue, twice: the two smallest agree to a few percent.
    assert p["lambda_next"] < 2 * p["lambda_min"]
    assert abs(p["lambda_min"] - line.point["lambda_min"]) <= 0.05 * line.point["lambda_min"]
    assert "the two smallest eigenvalues are nearly equal" in p["note"], p["note"]
    assert "nearly equal" not in line.point["note"]

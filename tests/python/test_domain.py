"""A path that leaves the domain of L solves no discrete problem: L = x'^2/2 + log(x) from x = -1
to x = 2 has DEL equations x'' = 1/x whose terms are finite at x < 0, where log(x) is NaN. The
minimizing Newton stops at once (non-finite action); Newton on the DEL residual (auto's second
attempt) drove the residual to 4.5e-12 with four nodes below 0 and was reported converged, a
saddle, with action NaN. Now the status is non_finite and the message says why."""
import numpy as np

import pardel

LOG_LAG = """\
model log_potential
coords x
L = x'^2/2 + log(x)
"""


def test_a_path_outside_the_domain_of_l_is_not_converged():
    r = pardel.solve(LOG_LAG, q0=[-1], qN=[2], T=1, N=10)
    assert r.status == "non_finite", r.message
    assert "leaves the domain of L" in r.message
    assert not np.isfinite(r.error_estimate)
    direct = pardel.solve(LOG_LAG, q0=[-1], qN=[2], T=1, N=10, method="stationary-newton")
    assert direct.status == "non_finite" and "the discrete action is NaN" in direct.message, direct.message
    assert (direct.q[:, 0] < 0).any()  # the iterate it stopped at, whose DEL residual is small
    batch = pardel.solve_batch(LOG_LAG, q0=[-1], qN=[[2], [3]], T=1, N=10, method="stationary-newton")
    assert list(batch.status) == ["non_finite", "non_finite"]


def test_the_same_model_inside_its_domain_converges():
    r = pardel.solve(LOG_LAG, q0=[1], qN=[2], T=1, N=10)
    assert r.status == "converged" and np.isfinite(r.action), r.message

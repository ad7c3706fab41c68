"""pardel.solve on .lag text: the answer is the exact solution of the discrete Euler-Lagrange
recursion, approaches the continuous one at second order, has the documented shapes, and reports
momenta, the point's inertia and smallest Hessian eigenvalues, the cost and the history; a saddle
past a conjugate point by stationary-newton and by the automatic method's second attempt."""
import math

import numpy as np
import pytest

import pardel

A, B, T = 1.5, 0.7, 2.0


@pytest.mark.parametrize("discretization", ["trapezoid", "midpoint"])
def test_exact_discrete_solution(spring_lag, exact, discretization):
    N = 40
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=N, discretization=discretization)
    assert r.status == "converged"
    assert r.q.shape == (N + 1, 2)
    assert r.t.shape == (N + 1,)
    np.testing.assert_allclose(r.t, np.linspace(0, T, N + 1), rtol=0, atol=1e-14)
    np.testing.assert_allclose(r.q[:, 0], exact(A, T, N, 1.0, discretization), rtol=0, atol=1e-10)
    np.testing.assert_allclose(r.q[:, 1], exact(B, T, N, 2.0, discretization), rtol=0, atol=1e-10)
    np.testing.assert_allclose(r.coordinate("y"), r.q[:, 1])


def test_second_order_convergence_to_the_continuous_solution(spring_lag):
    def error(N):
        r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=N)
        x = np.sin(A * r.t) / math.sin(A * T)
        return np.abs(r.q[:, 0] - x).max()

    e = [error(N) for N in (20, 40, 80)]
    assert e[0] < 0.2
    for coarse, fine in zip(e, e[1:]):
        assert 3.5 < coarse / fine < 4.5


def test_a_saddle_past_the_conjugate_point_by_method_name_and_by_default(spring_lag, exact):
    # T = 3 lies past the first conjugate time pi/1.5 of the x spring (and before pi/0.7 of the y
    # spring): the DEL solution is a saddle of index 1, which stationary-newton converges to and
    # the automatic method reaches by its second attempt.
    N, duration = 60, 3.0
    for method in ("stationary-newton", "auto"):
        r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=duration, N=N, method=method)
        assert r.status == "converged", r.message
        assert r.point["kind"] == "saddle"
        assert r.point["inertia"] == {"positive": 2 * (N - 1) - 1, "negative": 1, "zero": 0}
        np.testing.assert_allclose(r.q[:, 0], exact(A, duration, N, 1.0, "trapezoid"), rtol=0, atol=1e-10)
        np.testing.assert_allclose(r.q[:, 1], exact(B, duration, N, 2.0, "trapezoid"), rtol=0, atol=1e-10)
    assert "after the minimizing Newton found no minimum" in r.message


def test_an_interruption_in_the_automatic_methods_second_attempt_ends_interrupted(spring_lag, tmp_path):
    # The same saddle: the minimizing Newton diverges first, then stationary-newton runs from the
    # straight line. Stopped by the callback at the second attempt's first record (the history's
    # last but one), the solve is interrupted (not the first attempt's divergence), with the second
    # attempt's iterate (its start) and no checkpoint (a resume would not continue it).
    N, duration = 60, 3.0
    whole = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=duration, N=N)
    assert "after the minimizing Newton found no minimum" in whole.message
    stop_on_call = len(whole.history["iteration"]) - 1
    calls = []

    def callback(i, n, res, a):
        calls.append(i)
        return len(calls) < stop_on_call

    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=duration, N=N, on_iteration=callback,
                     checkpoint=str(tmp_path))
    assert r.status == "interrupted" and r.stopped_by_callback, r.message
    assert "during Newton on the DEL residual (stationary-newton) from the same start" in r.message
    assert "the automatic method's attempt after the first ended diverged" in r.message
    assert "not resumable" in r.message and r.checkpoint is None
    assert not (tmp_path / "checkpoint.json").exists()
    assert r.point["kind"] == "unknown"
    np.testing.assert_allclose(r.q, np.linspace([0, 0], [1, 2], N + 1), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(r.history["iteration"], whole.history["iteration"][:-1])


def test_params_by_name_and_by_position(spring_lag, exact):
    N = 30
    by_name = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 1], T=T, N=N, params={"b": 1.1})
    by_position = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 1], T=T, N=N, params=[1.5, 1.1])
    np.testing.assert_allclose(by_name.q[:, 1], exact(1.1, T, N, 1.0, "trapezoid"), atol=1e-10)
    np.testing.assert_array_equal(by_name.q, by_position.q)
    np.testing.assert_allclose(by_name.q[:, 0], exact(A, T, N, 1.0, "trapezoid"), atol=1e-10)


def test_boundary_momenta_approach_the_continuous_velocities(spring_lag):
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=200)
    assert r.p0.shape == (2,) and r.pN.shape == (2,)
    v0 = np.array([A / math.sin(A * T), 2 * B / math.sin(B * T)])
    vT = np.array([A * math.cos(A * T) / math.sin(A * T), 2 * B * math.cos(B * T) / math.sin(B * T)])
    np.testing.assert_allclose(r.p0, v0, rtol=1e-3)
    np.testing.assert_allclose(r.pN, vT, rtol=1e-3)


def test_boundary_momenta_in_the_summary_and_exact_for_a_free_particle():
    # A free particle moves at the constant velocity (qN - q0) / T, and both discretizations give
    # it exactly: the discrete momenta are that velocity, and summary.json holds the same numbers.
    q0, qN, duration = np.array([0.5, -1.0]), np.array([2.0, 3.0]), 2.5
    for discretization in ("trapezoid", "midpoint"):
        r = pardel.solve("free_particle", q0=q0, qN=qN, T=duration, N=20, discretization=discretization)
        assert r.status == "converged"
        np.testing.assert_allclose(r.p0, (qN - q0) / duration, rtol=0, atol=1e-12)
        np.testing.assert_allclose(r.pN, (qN - q0) / duration, rtol=0, atol=1e-12)
        assert r.summary["boundary_momenta"] == {"p0": list(r.p0), "pN": list(r.pN)}


def test_summary_fields(spring_lag):
    N = 50
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=N)
    # A T = 3 < pi and B T < pi: the Hessian of the action is positive definite, N - 1 free nodes.
    assert r.point["kind"] == "minimum"
    assert r.point["inertia"] == {"positive": 2 * (N - 1), "negative": 0, "zero": 0}
    assert r.cost_name == "action"
    assert r.cost == pytest.approx(r.action)
    assert r.iterations >= 1 and r.residual <= r.summary["tolerance"]
    assert set(r.history) == {"iteration", "N", "residual", "action", "seconds"}
    assert len(r.history["residual"]) >= 1 and r.history["N"][-1] == N
    assert r.summary["model"] == "aniso_spring"


def test_smallest_eigenvalues_of_the_hessian(spring_lag):
    # Trapezoid: the Hessian is diagonal per coordinate, tridiag(-1/h, 2/h - h w^2, -1/h), with
    # eigenvalues (2 - 2 cos(pi j / N)) / h - h w^2, j = 1..N-1, for w = a and w = b.
    N = 50
    h = T / N
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=N)
    exact = sorted((2 - 2 * math.cos(math.pi * j / N)) / h - h * w * w for j in range(1, N) for w in (A, B))
    assert r.point["lambda_min"] == pytest.approx(exact[0], rel=1e-8)
    assert r.point["lambda_next"] == pytest.approx(exact[1], rel=1e-3)
    assert r.point["lambda_next"] >= exact[1] * (1 - 1e-12)


def test_guess_array_and_previous_result(spring_lag):
    coarse = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=20)
    fine = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=40, guess=coarse)
    direct = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=40)
    np.testing.assert_allclose(fine.q, direct.q, atol=1e-10)
    with pytest.raises(pardel.PardelError, match=r"guess: shape \(41, 3\)"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=40, guess=np.zeros((41, 3)))


def test_on_iteration_can_stop_the_solve(spring_lag):
    seen = []

    def stop_after_five(iteration, N, residual, action):
        seen.append(iteration)
        return len(seen) < 5

    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=T, N=200, method="jacobi-newton",
                     on_iteration=stop_after_five)
    assert r.status == "interrupted"
    assert r.stopped_by_callback
    assert len(seen) == 5
    assert r.q.shape == (201, 2)


HARMONIC_LAG = """\
# x'' = -x: past its conjugate point (T > pi) the action has no minimum, only a saddle
model past_conjugate
coords x
L = 1/2*x'^2 - 1/2*x^2
discretizations trapezoid
"""


def test_on_iteration_numbers_the_automatic_methods_second_attempt_as_the_history(spring_lag):
    # auto's minimizing Newton finds no minimum (T = 4 > pi); stationary-newton, its second attempt
    # from the same start, converges to the saddle. The callback sees every recorded iteration of
    # both, numbered as the history numbers them.
    seen = []
    r = pardel.solve(HARMONIC_LAG, q0=[0.0], qN=[1.0], T=4, N=80,
                     on_iteration=lambda iteration, N, residual, action: seen.append(iteration))
    assert r.status == "converged" and r.method == "stationary-newton", r.message
    assert seen == list(r.history["iteration"])
    assert seen[-1] == r.iterations


@pytest.mark.parametrize("environment,expected", [({}, "passive"), ({"OMP_WAIT_POLICY": "active"}, "active"),
                                                  ({"GOMP_SPINCOUNT": "1000"}, "default")])
def test_openmp_threads_wait_passively_unless_the_user_chose(environment, expected):
    # Importing pardel sets OMP_WAIT_POLICY=passive before OpenMP starts (docs/solvers.md) unless the
    # user set the policy; a solve's summary says which policy it ran with. A fresh interpreter,
    # as OpenMP reads the variable once.
    import os
    import subprocess
    import sys
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    env.update(environment)
    code = ("import pardel; r = pardel.solve('fuel_nav', q0=[0, 0], qN=[6, 5], T=8, N=40, threads=2); "
            "print(r.status, r.summary['openmp_wait_policy'])")
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True).stdout
    assert out.split() == ["converged", expected]


def test_a_discrete_conjugate_point_is_degenerate_and_its_residual_is_noted():
    # x'' + w^2 x = 0 under the trapezoid rule, with w chosen so that the DEL recursion
    # x_{k+1} + x_{k-1} = (2 - h^2 w^2) x_k has angle pi/N: the interior system is singular, and with
    # x_0 = 0, x_N = 1 it has no solution of moderate size. The relative test can be met by an
    # iterate that walked along the zero direction; the note must say that the residual is far
    # above round-off and the trajectory undetermined there.
    N, duration = 10, 1.0
    h = duration / N
    w = (2 / h) * math.sin(math.pi / (2 * N))
    r = pardel.solve("harmonic", q0=[0], qN=[1], T=duration, N=N, params={"omega": w}, discretization="trapezoid")
    x = r.q[:, 0]
    # Independent truth: the interior system's matrix, written out here, is singular to working precision.
    c = 2 - (h * w) ** 2
    A = np.diag(np.full(N - 1, -c)) + np.diag(np.ones(N - 2), 1) + np.diag(np.ones(N - 2), -1)
    assert np.linalg.cond(A) > 1e14
    # The DEL equations at pardel's iterate do not hold in absolute terms (end values of size 1) ...
    del_residual = np.abs(x[2:] + x[:-2] - c * x[1:-1]).max() / h
    assert del_residual > 0.1
    if r.status == "converged":
        # ... so a converged status comes with a degenerate point whose note says so.
        assert r.point["kind"] == "degenerate", r.point
        assert "times its round-off level: along the zero direction(s) the tolerance" in r.point["note"]
        assert "no solution near here" in r.point["note"]
    else:
        assert r.point["kind"] == "unknown"


def test_a_lagrangian_singular_at_a_fixed_end_is_assessed_on_the_interior():
    # L = x'^2/2 + 1/x with x(0) = 0: the second derivatives at the fixed end are infinite (so is
    # the action), but they do not enter the Hessian of the interior unknowns, which is positive
    # definite here. The point is assessed on it, not left "unknown" with no note.
    N, duration = 8, 1.0
    r = pardel.solve("model divzero_end\ncoords x\nL = 1/2*x'^2 + 1/x\n", q0=[0], qN=[1], T=duration, N=N)
    assert r.status == "converged", r.message
    x, h = r.q[:, 0], duration / N
    # Independent truth: the trapezoid DEL residual and the Hessian written out here.
    assert np.abs((2 * x[1:-1] - x[:-2] - x[2:]) / h - h / x[1:-1] ** 2).max() < 1e-9
    H = np.diag(2 / h + 2 * h / x[1:-1] ** 3) + np.diag(np.full(N - 2, -1 / h), 1) + np.diag(np.full(N - 2, -1 / h), -1)
    eigenvalues = np.linalg.eigvalsh(H)
    assert eigenvalues[0] > 0
    assert r.point["kind"] == "minimum", r.point
    # A Ritz value: an upper bound, settled to 1e-4 of the value (docs/solvers.md).
    assert eigenvalues[0] <= r.point["lambda_min"] <= eigenvalues[0] * (1 + 1e-4)


def test_iterates_that_slide_off_past_a_conjugate_point_are_not_called_converged():
    # x'' + x = 0 under the trapezoid rule, N = 40, T a hair (1e-9 relative) past the first discrete
    # conjugate time: the DEL solution is a saddle of size 3e8. The minimizing Newton slides down the
    # negative direction; its iterates grow faster than their residual, which meets the relative
    # test there while growing 60-fold: that is no convergence. The automatic method's second
    # attempt (stationary-newton) reaches the saddle.
    N = 40
    conjugate_T = N * math.sqrt(2 * (1 - math.cos(math.pi / N)))
    duration = conjugate_T * (1 + 1e-9)
    h = duration / N
    c = 2 - h * h
    A = np.diag(np.full(N - 1, -c)) + np.diag(np.ones(N - 2), 1) + np.diag(np.ones(N - 2), -1)
    b = np.zeros(N - 1)
    b[-1] = -1.0
    exact = np.concatenate([[0.0], np.linalg.solve(A, b), [1.0]])
    assert np.abs(exact).max() > 1e8
    newton = pardel.solve("harmonic", q0=[0], qN=[1], T=duration, N=N, discretization="trapezoid", method="newton")
    assert newton.status != "converged", newton.message
    auto = pardel.solve("harmonic", q0=[0], qN=[1], T=duration, N=N, discretization="trapezoid")
    assert auto.status == "converged" and auto.point["kind"] == "saddle", auto.message
    assert np.abs(auto.q[:, 0] - exact).max() < 1e-3 * np.abs(exact).max()


def test_a_high_order_galerkin_solve_of_a_linear_model_takes_one_newton_iteration():
    # L = x''^2/2 + c x'^2/2 (c = 4): x'''' = 4 x'', exact x = a + b t + e cosh 2t + f sinh 2t.
    # Under galerkin_gauss(s=6) and (s=8) the elimination of interior values at points amplified
    # rounding far above the level the terms' sizes give (its node blocks 1e-13 off): Newton crept
    # 31-102 iterations and stalled at the round-off level it then measured. Over the Hermite
    # interpolant plus orthogonal bubbles the condensed blocks are as accurate as the node blocks,
    # and Newton solves the linear problem in one iteration.
    lag = "model stiff_beam_s\norder 2\ncoords x\nparam c = 4\nL = x''^2/2 + c*x'^2/2\n" \
          "discretizations galerkin_gauss(s=6) galerkin_gauss(s=8)\n"

    def basis(t):
        return np.array([np.ones_like(t), t, np.cosh(2 * t), np.sinh(2 * t)])

    def dbasis(t):
        return np.array([np.zeros_like(t), np.ones_like(t), 2 * np.sinh(2 * t), 2 * np.cosh(2 * t)])

    M = np.array([basis(np.array(0.0)), dbasis(np.array(0.0)), basis(np.array(1.0)), dbasis(np.array(1.0))])
    coef = np.linalg.solve(M, [0, 1, 1, 0])
    for discretization, N in (("galerkin_gauss(s=6)", 20), ("galerkin_gauss(s=8)", 40), ("galerkin_gauss(s=8)", 640)):
        r = pardel.solve(lag, q0=[0, 1], qN=[1, 0], T=1.0, N=N, discretization=discretization)
        assert r.status == "converged" and r.point["kind"] == "minimum", r.message
        assert np.abs(r.q[:, 0] - coef @ basis(r.t)).max() < 1e-12
        assert r.iterations <= 2, r.iterations
        assert "the round-off level was measured" not in r.message


def cancelling_truth(K, N, T, xb):
    """The trapezoid DEL solution of L = x'^2/2 + K (cosh x - 1 - x^2/2) - x with x(0) = 0,
    x(T) = xb: (x[k+1] - 2 x[k] + x[k-1]) / h = h (K (sinh x[k] - x[k]) - 1), by Newton's method in
    40-digit arithmetic."""
    import mpmath as mp
    with mp.workdps(40):
        return _cancelling_newton(mp, K, N, T, xb)


def _cancelling_newton(mp, K, N, T, xb):
    h, K = mp.mpf(T) / N, mp.mpf(K)
    x = [mp.mpf(xb) * k / N for k in range(N + 1)]
    for _ in range(60):
        F = [(x[k + 1] - 2 * x[k] + x[k - 1]) / h - h * (K * (mp.sinh(x[k]) - x[k]) - 1) for k in range(1, N)]
        d = [-2 / h - h * K * (mp.cosh(x[k]) - 1) for k in range(1, N)]
        c, r = [mp.mpf(0)] * (N - 1), [mp.mpf(0)] * (N - 1)  # Thomas, off-diagonals 1/h
        c[0], r[0] = (1 / h) / d[0], F[0] / d[0]
        for i in range(1, N - 1):
            m = d[i] - c[i - 1] / h
            c[i], r[i] = (1 / h) / m, (F[i] - r[i - 1] / h) / m
        for i in range(N - 2, -1, -1):
            r[i] -= c[i] * r[i + 1] if i < N - 2 else 0
            x[i + 1] -= r[i]
        if max(abs(v) for v in r) < mp.mpf(10) ** -35:
            break
    return np.array([float(v) for v in x])


def test_a_stall_on_kernels_that_cancel_measures_the_round_off_level_and_converges():
    # K (sinh x - x) at x ~ 2e-4 cancels seven digits: the DEL residual's rounding lies far above
    # the level estimated from the terms' sizes (4e-16), and Newton stalls at 1e-10. The level
    # measured at the iterate makes it converged, and the message says so; the answer is the
    # discrete solution to within the rounding of the cancelled terms.
    lag = "model cancelling_cosh\ncoords x\nparam K = 1\nL = x'^2/2 + K*(cosh(x) - 1 - x^2/2) - x\n" \
          "discretizations trapezoid\n"
    r = pardel.solve(lag, q0=[0.0], qN=[0.001], T=1.0, N=400, discretization="trapezoid", params={"K": 1e12})
    assert r.status == "converged" and r.point["kind"] == "minimum", r.message
    assert "the round-off level was measured where Newton stalled" in r.message
    assert np.abs(r.q[:, 0] - cancelling_truth(1e12, 400, 1.0, 0.001)).max() < 5e-12


def test_on_iteration_sees_every_record_of_a_thinned_history_the_last_one_too():
    calls = []
    r = pardel.solve("fuel_nav", q0=[0, 0], qN=[6, 5], T=30, N=60, method="jacobi-newton",
                     on_iteration=lambda *record: calls.append(record))
    assert r.status == "converged", r.message
    assert len(r.history["iteration"]) > 100  # thinned: far fewer records than iterations
    assert [c[0] for c in calls] == list(r.history["iteration"])
    assert calls[-1][0] == r.iterations and calls[-1][2] == r.history["residual"][-1]


def test_a_stall_at_the_edge_of_the_double_range_says_so():
    # T = 1e308 over 10 intervals: the oscillator's action and DEL terms are near 1e307, where sums
    # overflow and steps' changes are lost; the stall names that, not the model's smoothness.
    r = pardel.solve("harmonic", q0=[0], qN=[1], T=1e308, N=10, method="newton")
    assert r.status == "stalled", r.message
    assert "within a factor 1e8 of the largest double" in r.message
    assert "not smooth" not in r.message

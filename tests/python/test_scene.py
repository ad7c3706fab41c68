"""Scenes from Python: load_scene + solve_scene give what pardel.solve gives for the same problem,
overrides apply, and check() returns the certificate of `pardel check`."""
import json
import math
import os
import subprocess

import numpy as np
import pytest

import pardel

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def write_scene(tmp_path, spring_lag):
    lag = tmp_path / "spring.lag"
    lag.write_text(spring_lag)
    scene = tmp_path / "spring.toml"
    scene.write_text('model = "spring.lag"\ndiscretization = "midpoint"\n[params]\na = 1.2\n'
                     '[grid]\nT = 2.0\nN = 30\n[boundary]\nq0 = [0, 0]\nqN = [1, 2]\n')
    return scene, lag


def test_scene_and_arguments_agree(tmp_path, spring_lag):
    scene_path, lag = write_scene(tmp_path, spring_lag)
    scene = pardel.load_scene(scene_path)
    assert scene.model == "aniso_spring" and scene.N == 30
    from_scene = pardel.solve_scene(scene)
    from_arguments = pardel.solve(lag, q0=[0, 0], qN=[1, 2], T=2.0, N=30, discretization="midpoint",
                                  params={"a": 1.2})
    np.testing.assert_array_equal(from_scene.q, from_arguments.q)
    assert from_scene.status == "converged"


def test_overrides(tmp_path, spring_lag):
    scene_path, _ = write_scene(tmp_path, spring_lag)
    r = pardel.solve_scene(pardel.load_scene(scene_path, ["grid.N=16"]))
    assert r.q.shape == (17, 2)


def test_seed_scene_solves():
    r = pardel.solve_scene(pardel.load_scene(os.path.join(ROOT, "scenes", "fuel_nav.toml")))
    assert r.status == "converged"
    assert r.cost_name == "fuel"
    assert r.q.shape == (201, 2)
    np.testing.assert_allclose(r.q[0], [0, 0])
    np.testing.assert_allclose(r.q[-1], [6, 5])


def test_check_returns_the_certificate(tmp_path, spring_lag):
    scene_path, _ = write_scene(tmp_path, spring_lag)
    scene = pardel.load_scene(scene_path)
    r = pardel.solve_scene(scene)
    c = pardel.check(scene, r)
    assert c["N"] == 30
    assert c["residual"] < 1e-8
    assert c["certificate"]["hessian_positive_definite"] is True
    assert c["certificate"]["inertia_positive"] == 2 * 29


def test_check_takes_the_trajectory_on_its_own_nodes_and_ends(tmp_path, spring_lag):
    scene_path, _ = write_scene(tmp_path, spring_lag)
    scene = pardel.load_scene(scene_path)
    r = pardel.solve_scene(scene)
    coarse = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2.0, N=15, discretization="midpoint", params={"a": 1.2})
    c = pardel.check(scene, coarse.q)  # 16 rows: checked on 15 intervals, not resampled to 30
    assert c["N"] == 15
    assert c["residual"] < 1e-8
    other = r.q.copy()
    other[-1, 0] += 1
    with pytest.raises(pardel.PardelError, match=r"^pardel\.check: q: node 30 has x = .* the scene's boundary\.qN"):
        pardel.check(scene, other)


def test_check_refuses_a_path_on_other_node_times(tmp_path, spring_lag):
    # The same spring problem on [0.5, 2.5] instead of [0, 2]: a Result carries its node times,
    # and they are not the scene's (the model is autonomous, so its residual alone would not tell).
    scene_path, _ = write_scene(tmp_path, spring_lag)
    scene = pardel.load_scene(scene_path)
    assert pardel.check(scene, pardel.solve_scene(scene))["residual"] < 1e-8
    later = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2.0, N=30, t0=0.5, discretization="midpoint",
                         params={"a": 1.2})
    with pytest.raises(pardel.PardelError, match=r"^pardel\.check: q: node 0 has t = 0\.5, the scene places it at "
                                                 r"t = 0 \(grid\.t0 = 0, grid\.T = 2, N = 30\)"):
        pardel.check(scene, later)


def test_check_of_an_adaptive_solution_takes_its_own_nodes(tmp_path, spring_lag):
    # grid.accuracy chooses a grid: the Result is checked on its node times (the solve's residual);
    # its array alone, without the times, is refused rather than taken on a uniform grid.
    scene_path, _ = write_scene(tmp_path, spring_lag)
    scene = pardel.load_scene(scene_path, ["grid.accuracy=1e-7"])
    r = pardel.solve_scene(scene)
    assert r.status == "converged"
    assert not np.allclose(np.diff(r.t), np.diff(r.t)[0])  # a non-uniform grid
    assert pardel.check(scene, r)["residual"] == pytest.approx(r.residual, rel=1e-6)
    with pytest.raises(pardel.PardelError, match=r"^pardel\.check: q: the scene chooses its grid"):
        pardel.check(scene, r.q)


def test_check_names_its_argument_q(tmp_path, spring_lag):
    scene_path, _ = write_scene(tmp_path, spring_lag)
    scene = pardel.load_scene(scene_path)
    with pytest.raises(pardel.PardelError, match=r"^pardel\.check: q: shape \(51, 3\) given; expected \(N\+1, 2\)"):
        pardel.check(scene, np.zeros((51, 3)))


def spring_jacobi_gap(omega, T, N):
    """1 - rho of block Jacobi for the midpoint rule of L = x'^2/2 - omega^2 x^2/2 on N intervals,
    both ends fixed: H is tridiagonal Toeplitz, diagonal 2 (1/h - h w^2/4), off-diagonal
    -(1/h + h w^2/4), so J = -D^{-1} C has eigenvalues (1/h + h w^2/4)/(1/h - h w^2/4) cos(k pi/N)."""
    h = T / N
    a, b = 1 / h + h * omega ** 2 / 4, 1 / h - h * omega ** 2 / 4
    return 1 - a / b * math.cos(math.pi / N)


def test_check_reports_every_member_of_the_certificate(tmp_path, spring_lag):
    # The spring's coordinates decouple: J's spectral radius is that of x (a = 1.2 > b = 0.7),
    # known in closed form; H is the same at every trajectory (L is quadratic).
    scene_path, _ = write_scene(tmp_path, spring_lag)
    scene = pardel.load_scene(scene_path)
    r = pardel.solve_scene(scene)
    c = pardel.check(scene, r)["certificate"]
    truth = spring_jacobi_gap(1.2, 2.0, 30)
    assert spring_jacobi_gap(0.7, 2.0, 30) > truth > 0
    assert c["spectral_radius_resolved"] is True
    assert c["spectral_radius_converged"] is True
    assert abs(c["jacobi_one_minus_rho"] - truth) <= 1e-8 * truth
    assert c["jacobi_spectral_radius"] == pytest.approx(1 - truth, abs=1e-12)
    # the round-off level of 1 - rho: a few units of eps times |y|^T |H| |y| ~ 2
    assert 0 < c["jacobi_one_minus_rho_roundoff"] < 1e-13
    assert c["free_components"] == 2 * 29
    # Every interval Hessian [[alpha, beta], [beta, alpha]], alpha = 1/h - h w^2/4 = A_k = B_k,
    # beta = -1/h - h w^2/4, per coordinate, has the eigenvalue alpha + beta = -h w^2/2 < 0: the
    # theorem's hypothesis fails on the 28 intervals whose two nodes are both free (the end
    # intervals are restricted to one node, 1 x 1 blocks alpha > 0), though H is positive definite.
    h = 2.0 / 30
    assert c["intervals_violating"] == 28 and c["violations_total"] == 28
    assert [v["k"] for v in c["violations"]] == list(range(1, 29))
    for v in c["violations"]:
        assert v["hessian_psd"] is False and v["A_pd"] is True and v["B_pd"] is True
        assert v["min_eig_hessian"] == pytest.approx(-h * 1.2 ** 2 / 2, rel=1e-9)
        assert v["min_eig_A"] == pytest.approx(1 / h - h * 1.2 ** 2 / 4, rel=1e-9)  # the x row of D11
        assert v["min_eig_B"] == v["min_eig_A"]
    assert c["all_intervals_psd"] is False and c["all_A_pd"] is True and c["theorem_holds"] is False
    assert c["hessian_positive_definite"] is True and c["inertia_negative"] == c["inertia_zero"] == 0
    assert c["error"] == ""
    assert c["tol"] == 1e-10  # certify's default target
    assert c["residual"] < 1e-8
    assert c["expected_iterations"] == 0  # the residual is already below tol
    assert "(58 free components)" in c["report"]
    assert "28 interval(s) violate a hypothesis" in c["report"]
    assert "(1 - rho = %.6e, round-off level" % c["jacobi_one_minus_rho"] in c["report"]


def test_summary_is_the_command_lines_summary_json(tmp_path, spring_lag):
    """Result.summary, made from the C++ summary without JSON text, is what Python's json module reads
    from the summary.json `pardel solve` writes for the same scene: the same keys in the same order,
    the same values (the times of the run apart), null where a number is not finite."""
    cli = os.environ.get("PARDEL_CLI")
    if not cli:
        pytest.skip("PARDEL_CLI (the pardel command line) is not set")
    scene_path, _ = write_scene(tmp_path, spring_lag)
    from_python = pardel.solve_scene(pardel.load_scene(scene_path)).summary
    done = subprocess.run([cli, "solve", str(scene_path), "--out", str(tmp_path / "out"), "--quiet"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "out" / "summary.json", encoding="utf-8") as f:
        from_cli = json.load(f)

    def without_times(value):
        if isinstance(value, dict):
            return {k: without_times(v) for k, v in value.items() if k not in ("wall_seconds", "assessment_seconds", "error_seconds", "seconds")}
        if isinstance(value, list):
            return [without_times(v) for v in value]
        return value

    assert list(from_python) == [k for k in from_cli if k in from_python]
    assert from_python["status"] == "converged" and from_python["N"] == 30
    expected = without_times(from_cli)
    for key, value in without_times(from_python).items():
        assert value == expected[key], key
    assert isinstance(from_python["wall_seconds"], float) and isinstance(from_python["iterations"], int)


def test_check_agrees_with_the_command_line(tmp_path, spring_lag):
    cli = os.environ.get("PARDEL_CLI")
    if not cli:
        pytest.skip("PARDEL_CLI (the pardel command line) is not set")
    scene_path, _ = write_scene(tmp_path, spring_lag)
    from_python = pardel.check(pardel.load_scene(scene_path))
    done = subprocess.run([cli, "check", str(scene_path), "--json"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    from_cli = json.loads(done.stdout)
    assert from_python["N"] == from_cli["N"] and from_python["residual"] == from_cli["residual"]
    for key, value in from_cli["certificate"].items():
        assert from_python["certificate"][key] == value, key
    for key in ("jacobi_one_minus_rho", "jacobi_one_minus_rho_roundoff", "spectral_radius_resolved"):
        assert key in from_cli["certificate"]
    truth = spring_jacobi_gap(1.2, 2.0, 30)
    assert abs(from_cli["certificate"]["jacobi_one_minus_rho"] - truth) <= 1e-8 * truth
    # what the dictionary of `pardel check --json` leaves out, Python adds
    extra = set(from_python["certificate"]) - set(from_cli["certificate"])
    assert extra == {"report"}
    text = subprocess.run([cli, "check", str(scene_path)], capture_output=True, text=True)
    assert text.returncode == 0, text.stderr
    assert text.stdout.endswith(from_python["certificate"]["report"])


UNITS_LAG = """\
# two free particles in units 24 decades apart: a mass of 1e12 and one of 1e-12
model far_units
coords x y
param m1 = 1e12
param m2 = 1e-12
L = 1/2*(m1*x'^2 + m2*y'^2)
discretizations trapezoid
"""


def test_the_certificate_judges_blocks_in_their_own_units(tmp_path):
    # Each interval's Hessian is (1/h) [[m, -m], [-m, m]] per coordinate: positive semi-definite,
    # with A_k = B_k = diag(m1, m2)/h = diag(8e12, 8e-12) positive definite.
    (tmp_path / "far_units.lag").write_text(UNITS_LAG)
    (tmp_path / "scene.toml").write_text(
        'model = "far_units.lag"\ndiscretization = "trapezoid"\n[grid]\nT = 1\nN = 8\n'
        '[boundary]\nq0 = [0, 0]\nqN = [2e-8, 3e8]\n[output]\ndir = "%s"\n' % (tmp_path / "out"))
    scene = pardel.load_scene(str(tmp_path / "scene.toml"))
    r = pardel.solve_scene(scene)
    assert r.status == "converged" and r.point["kind"] == "minimum", r.message
    c = pardel.check(scene, r)["certificate"]
    assert c["all_intervals_psd"] and c["all_A_pd"] and c["all_B_pd"] and c["theorem_holds"], c["report"]
    assert c["intervals_violating"] == 0


SCALED_COSINE_LAG = """\
# a coercive action in units 24 decades apart: L = (1e12 x'^2 + 1e-12 y'^2)/2 - cos(1e8 x + 1e-8 y)
model scaled_cosine
coords x y
L = 1/2*(1e12*x'^2 + 1e-12*y'^2) - cos(1e8*x + 1e-8*y)
discretizations trapezoid
"""


def test_a_stall_on_coordinates_of_far_apart_units_says_so():
    # Newton's steps in the kinetic metric of both coordinates find no decrease of the action at
    # a residual far above round-off; the model is smooth, and the message names the units.
    r = pardel.solve(SCALED_COSINE_LAG, q0=[0, 0], qN=[2e-8, 3e8], T=1, N=8, method="newton")
    assert r.status == "stalled", r.message
    assert "the Hessian's diagonal spans a factor" in r.message and 'newton_shift = "identity"' in r.message
    r = pardel.solve(SCALED_COSINE_LAG, q0=[0, 0], qN=[2e-8, 3e8], T=1, N=8, method="newton",
                     newton_shift="identity")
    assert r.status == "converged" and r.point["kind"] == "minimum", r.message


def test_the_automatic_method_retries_such_a_stall_in_the_identity_metric():
    r = pardel.solve(SCALED_COSINE_LAG, q0=[0, 0], qN=[2e-8, 3e8], T=1, N=8)
    assert r.status == "converged" and r.point["kind"] == "minimum", r.message
    assert "in the identity metric (newton_shift = identity), retried from where" in r.message
    # The round-off bound of the point note counts both coordinates in one norm, and says so.
    assert "a bound over all coordinates in one norm: the Hessian's diagonal spans a factor" in r.point["note"]
    # Independent truth: the trapezoid action S = sum_k h [m1 vx^2/2 + m2 vy^2/2 - (cos th_k + cos th_k+1)/2],
    # th = a x + b y, written out here; its gradient vanishes at the interior nodes to round-off
    # of each coordinate's terms, and its Jacobi-scaled Hessian there is positive definite.
    m1, m2, a, b, h = 1e12, 1e-12, 1e8, 1e-8, 1 / 8
    x, y = r.q[:, 0], r.q[:, 1]
    th = a * x + b * y
    kin_x = m1 * (2 * x[1:-1] - x[:-2] - x[2:]) / h
    kin_y = m2 * (2 * y[1:-1] - y[:-2] - y[2:]) / h
    gx, gy = kin_x + h * a * np.sin(th[1:-1]), kin_y + h * b * np.sin(th[1:-1])
    size_x = np.abs(m1 * np.diff(x) / h).max() + h * a
    size_y = np.abs(m2 * np.diff(y) / h).max() + h * b
    assert np.abs(gx).max() <= 1e-9 * size_x and np.abs(gy).max() <= 1e-9 * size_y
    n = len(x) - 2
    H = np.zeros((2 * n, 2 * n))
    for k in range(n):
        c = h * np.cos(th[k + 1])
        H[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[2 * m1 / h + c * a * a, c * a * b], [c * a * b, 2 * m2 / h + c * b * b]]
        if k + 1 < n:
            H[2 * k, 2 * k + 2] = H[2 * k + 2, 2 * k] = -m1 / h
            H[2 * k + 1, 2 * k + 3] = H[2 * k + 3, 2 * k + 1] = -m2 / h
    J = 1 / np.sqrt(np.abs(np.diag(H)))
    assert np.linalg.eigvalsh(J[:, None] * H * J[None, :]).min() > 1e-6


def test_an_interruption_in_the_identity_metric_retry_ends_interrupted(tmp_path):
    # Stopped by the callback in the retry, after its second step, the solve is interrupted with the
    # retry's iterate (not the first attempt's stall), and no checkpoint is written.
    whole = pardel.solve(SCALED_COSINE_LAG, q0=[0, 0], qN=[2e-8, 3e8], T=1, N=8)
    iterations = list(whole.history["iteration"])
    first_records = next(k for k in range(1, len(iterations)) if iterations[k] == iterations[k - 1])
    calls = []

    def callback(i, n, res, a):
        calls.append(i)
        return len(calls) < first_records + 4

    r = pardel.solve(SCALED_COSINE_LAG, q0=[0, 0], qN=[2e-8, 3e8], T=1, N=8, on_iteration=callback,
                     checkpoint=str(tmp_path))
    assert r.status == "interrupted" and r.stopped_by_callback, r.message
    assert "during a retry from there in the identity metric (newton_shift = identity)" in r.message
    assert "the automatic method's attempt after the first ended stalled" in r.message
    assert r.checkpoint is None and not (tmp_path / "checkpoint.json").exists()
    np.testing.assert_array_equal(r.history["iteration"], iterations[:first_records + 4])
    # The retry's iterate: its residual is far below the first attempt's where it stalled.
    assert r.residual < 1e-3 * whole.history["residual"][first_records - 1]

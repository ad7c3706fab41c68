"""Scenes from Python: load_scene + solve_scene give what pardel.solve gives for the same problem,
overrides apply, and check() returns the certificate of `pardel check`."""
import os

import numpy as np

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

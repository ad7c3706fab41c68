"""Errors raised as Python exceptions with the command line's messages: unknown options named
with a suggestion, bad values naming the scene key, scene files with FILE:LINE:COL."""
import pytest

import pardel


def test_unknown_option_is_named(spring_lag):
    with pytest.raises(pardel.PardelError) as info:
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, max_iteration=5)
    assert "unknown option 'max_iteration'" in str(info.value)
    assert "did you mean 'max_iterations'" in str(info.value)


def test_bad_values_name_the_key(spring_lag):
    with pytest.raises(pardel.PardelError, match=r"solver\.rtol must be in \(0, 1\), got 2"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, rtol=2.0)
    with pytest.raises(pardel.PardelError, match=r"boundary\.qN has 3 values; expected 2"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2, 3], T=1, N=10)
    with pytest.raises(pardel.PardelError, match=r"unknown method 'newtn'.*did you mean 'newton'"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, method="newtn")
    with pytest.raises(pardel.PardelError, match=r"params"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, params={"c": 1.0})
    with pytest.raises(pardel.PardelError, match=r"history_every"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, history_every=0)


def test_bad_values_break_the_bounds_of_the_runtime_options(spring_lag):
    with pytest.raises(pardel.PardelError, match=r"solver\.newton_substeps must be between 1 and 1000, got 1001"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, newton_substeps=1001)
    with pytest.raises(pardel.PardelError, match=r"threads: an integer in \[1, 4096\] was expected, got 4097"):
        pardel.sweep("no_such_sweep.toml", threads=4097)
    # An option outside the scene schema: Options::is_valid's message, with the same bound.
    with pytest.raises(pardel.PardelError, match=r"option divergence_factor = 1 is invalid: must be > 1"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, divergence_factor=1.0)


def test_scene_errors_carry_file_line_and_column(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text('model = "fuel_nav"\n[grid]\nT = 30\nN = 200\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n'
                     '[solver]\ntoll = 1e-9\n')
    with pytest.raises(pardel.SceneError) as info:
        pardel.load_scene(scene)
    message = str(info.value)
    assert message.startswith("%s:9:1: error:" % scene)
    assert "solver.toll" in message and "did you mean" in message


def test_override_errors_name_the_override():
    with pytest.raises(pardel.SceneError, match=r"--set grid\.N=1: error: grid\.N must be between 2"):
        pardel.load_scene("scenes/fuel_nav.toml", ["grid.N=1"])

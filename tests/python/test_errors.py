"""Errors raised as Python exceptions: unknown options named with a suggestion, option values
outside the runtime's bounds naming the argument, values the scene reader refuses naming the scene
key, scene files with FILE:LINE:COL (test_argument_types.py: wrong types and values of every
argument)."""
import pytest

import pardel


def test_unknown_option_is_named(spring_lag):
    with pytest.raises(pardel.PardelError) as info:
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, max_iteration=5)
    assert "unknown option 'max_iteration'" in str(info.value)
    assert "did you mean 'max_iterations'" in str(info.value)


def test_bad_values_name_the_key(spring_lag):
    with pytest.raises(pardel.PardelError, match=r"^pardel\.solve: rtol must be in \(0, 1\), got 2\.0$"):
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
    with pytest.raises(pardel.PardelError, match=r"^pardel\.solve: newton_substeps must be an int between 1 and 1000, "
                                                 r"got 1001$"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, newton_substeps=1001)
    with pytest.raises(pardel.PardelError, match=r"^pardel\.sweep: threads must be an int between 0 and 4096, got 4097$"):
        pardel.sweep("no_such_sweep.toml", threads=4097)
    # An option outside the scene schema: the same bound (pardel::option_bound) and rule.
    with pytest.raises(pardel.PardelError, match=r"^pardel\.solve: divergence_factor must be > 1, got 1\.0$"):
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


def test_device_is_checked_and_a_refused_device_solve_names_the_device(spring_lag):
    with pytest.raises(pardel.PardelError, match=r"unknown device 'gpu'"):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, device="gpu")
    # Hybrid does not run on the device (and a build or machine without CUDA refuses it too).
    with pytest.raises(pardel.PardelError, match=r"device cuda: "):
        pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, device="cuda", method="hybrid")


def test_a_time_origin_too_large_for_the_step_is_named(tmp_path):
    # T / N = 0.0156 is a fine step; next to t0 = 1e308 the node times round to one another.
    scene = tmp_path / "far.toml"
    scene.write_text('model = "fuel_nav"\n[grid]\nt0 = 1e308\nT = 1\nN = 64\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n')
    with pytest.raises(pardel.SceneError, match=r"far\.toml:3:6: error: grid\.t0 = 1e\+308 is too large for the step"):
        pardel.load_scene(scene)
    with pytest.raises(pardel.SceneError, match=r"--set grid\.t0=1e300: error: grid\.t0 = 1e\+300 is too large"):
        pardel.load_scene(scene, ["grid.t0=1e300"])


def test_a_misspelled_option_is_named_even_with_the_value_none(spring_lag, tmp_path):
    # None stands for "not given" for a known option; for an unknown name it is still an error.
    for call in (lambda: pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, acuracy=None),
                 lambda: pardel.solve_batch(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, foo=None)):
        with pytest.raises(pardel.PardelError, match="unknown option"):
            call()
    pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=10, accuracy=None, guess=None)  # known names: fine
    pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=1, N=200, method="jacobi", max_iterations=50,
                 checkpoint=str(tmp_path), on_iteration=lambda i, *rest: i < 3)
    with pytest.raises(pardel.PardelError, match="unknown option 'methd'; did you mean 'method'"):
        pardel.resume(str(tmp_path), methd=None)


def test_plot_path_of_one_coordinate_is_a_pardel_error():
    import matplotlib

    matplotlib.use("Agg")
    import pardel.plot

    r = pardel.solve("harmonic", q0=[0], qN=[1], T=1, N=10)
    with pytest.raises(pardel.PardelError, match="the model has one coordinate"):
        pardel.plot.path(r)


def test_a_polyline_of_one_point_is_named_as_the_argument():
    with pytest.raises(pardel.PardelError, match=r"^pardel\.solve: polyline must have at least 2 points"):
        pardel.solve("fuel_nav", q0=[0, 0], qN=[6, 5], T=30, N=50, polyline=[[3, 0]])

"""Models from Python: bundled names, .lag files and .lag text (compiled through the model loader),
their description, kernels checked against finite differences of Ld, and .lag errors raised with
FILE:LINE:COL as the command line prints them; the generator's warnings as pardel.ModelWarning."""
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

import pardel


def test_bundled_names():
    names = pardel.models()
    assert "fuel_nav" in names
    m = pardel.model("fuel_nav")
    assert m.coords == ["x", "y"] and m.order == 1 and m.dim == 2


def test_lag_text_and_file_give_the_same_model(spring_lag, tmp_path):
    from_text = pardel.model(spring_lag)
    path = tmp_path / "spring.lag"
    path.write_text(spring_lag)
    from_file = pardel.model(str(path))
    assert from_text.name == from_file.name == "aniso_spring"
    assert from_text.params == {"a": 1.5, "b": 0.7}
    assert from_text.discretizations == ["trapezoid", "midpoint"]
    r1 = pardel.solve(from_text, q0=[0, 0], qN=[1, 2], T=1, N=10)
    r2 = pardel.solve(path, q0=[0, 0], qN=[1, 2], T=1, N=10)
    np.testing.assert_array_equal(r1.q, r2.q)


def test_a_model_object_solves_with_its_compiled_model_and_a_path_reads_the_file_again(spring_lag, tmp_path):
    path = tmp_path / "spring.lag"
    path.write_text(spring_lag)
    model = pardel.model(str(path))
    before = pardel.solve(model, q0=[0, 0], qN=[1, 2], T=1, N=10)
    # The file now holds another model (stiffer x spring) and then a malformed one: the Model keeps
    # solving the one it compiled; the path and a new Model see the file as it is now.
    path.write_text(spring_lag.replace("param a = 1.5", "param a = 2.5"))
    np.testing.assert_array_equal(pardel.solve(model, q0=[0, 0], qN=[1, 2], T=1, N=10).q, before.q)
    batch = pardel.solve_batch(model, q0=[[0, 0]], qN=[[1, 2]], T=1, N=10)
    np.testing.assert_array_equal(batch[0].q, before.q)
    stiffer = pardel.solve(str(path), q0=[0, 0], qN=[1, 2], T=1, N=10)
    assert pardel.model(str(path)).params["a"] == 2.5
    assert np.max(np.abs(stiffer.q[:, 0] - before.q[:, 0])) > 1e-2
    path.write_text("model broken\norder 1\ncoords x\nL = x'^2 +\n")
    np.testing.assert_array_equal(pardel.solve(model, q0=[0, 0], qN=[1, 2], T=1, N=10).q, before.q)
    with pytest.raises(pardel.ModelError, match="spring.lag"):
        pardel.solve(str(path), q0=[0, 0], qN=[1, 2], T=1, N=10)


def test_kernels_match_finite_differences(spring_lag):
    q0, q1, h = [0.3, -0.2], [0.5, 0.1], 0.1
    k = pardel.kernels(spring_lag, "midpoint", h, 0.0, h, q0, q1, params={"a": 2.0})

    def Ld(a, b):
        return pardel.kernels(spring_lag, "midpoint", h, 0.0, h, a, b, params={"a": 2.0})["Ld"]

    eps = 1e-6
    for i in range(2):
        d = np.zeros(2)
        d[i] = eps
        D1 = (Ld(q0 + d, q1) - Ld(q0 - d, q1)) / (2 * eps)
        D2 = (Ld(q0, q1 + d) - Ld(q0, q1 - d)) / (2 * eps)
        assert k["D1"][i] == pytest.approx(D1, rel=1e-6, abs=1e-8)
        assert k["D2"][i] == pytest.approx(D2, rel=1e-6, abs=1e-8)
    # midpoint of L: Ld = |q1 - q0|^2/(2h) - h (a^2 xm^2 + b^2 ym^2)/2
    xm, ym = (q0[0] + q1[0]) / 2, (q0[1] + q1[1]) / 2
    expected = ((q1[0] - q0[0]) ** 2 + (q1[1] - q0[1]) ** 2) / (2 * h) - h * (4 * xm ** 2 + 0.49 * ym ** 2) / 2
    assert k["Ld"] == pytest.approx(expected, rel=1e-13)
    assert k["D11"].shape == (2, 2)


def test_invalid_lag_text_names_file_line_and_column(tmp_path):
    bad = "model broken\norder 1\ncoords x\nL = 1/2*x'^2 +* x\n"
    with pytest.raises(pardel.ModelError) as info:
        pardel.model(bad)
    message = str(info.value)
    assert message.splitlines()[0].startswith(pardel.lag_cache_dir())
    assert ".lag:4:" in message and "error:" in message


def test_invalid_lag_file_in_solve_is_a_scene_error(tmp_path):
    path = tmp_path / "typo.lag"
    path.write_text("model typo\norder 1\ncoords x\nL = 1/2*x'^2 - sinn(x)\n")
    with pytest.raises(pardel.PardelError) as info:
        pardel.solve(str(path), q0=[0], qN=[1], T=1, N=10)
    assert "%s:4:" % path in str(info.value)


def test_unknown_model_lists_the_compiled_ones():
    with pytest.raises(pardel.ModelError, match=r"unknown model 'fuel_nab' \(compiled models: .*fuel_nav"):
        pardel.model("fuel_nab")


# W = d2L/dq'dq' = diag(s, 1): singular on the line s = 0 only; pardel-gen accepts the model with
# a warning, which must reach the user although the model compiles.
FOLD_LAG = """\
# W = diag(s, 1): singular on the line s = 0 only
model fold_plane
coords r s
L = 1/2*(s*r'^2 + s'^2) - 1/2*(r^2 + s^2)
discretizations midpoint
"""
FOLD_WARNING = ("fold.lag:4:5: warning: model 'fold_plane': W = d2L/dq'dq' (the Hessian of L in r', s') is "
                "singular on part of the domain: det W = s changes sign between sample points and vanishes "
                "near s = 0")


def test_generator_warnings_are_issued_once_per_model(tmp_path):
    path = tmp_path / "fold.lag"
    path.write_text(FOLD_LAG)
    with pytest.warns(pardel.ModelWarning) as record:
        m = pardel.model(str(path))
    assert m.name == "fold_plane"
    messages = [str(w.message) for w in record if issubclass(w.category, pardel.ModelWarning)]
    assert len(messages) == 1
    assert messages[0].startswith("%s:4:5: warning: " % path)
    assert FOLD_WARNING in messages[0]
    assert "\n  L = 1/2*(s*r'^2 + s'^2) - 1/2*(r^2 + s^2)\n      ^" in messages[0]
    assert issubclass(pardel.ModelWarning, UserWarning)
    # once per model and process: solving with it warns no more
    with warnings.catch_warnings():
        warnings.simplefilter("error", pardel.ModelWarning)
        r = pardel.solve(path, q0=[0, 1], qN=[0.5, 1.5], T=1.0, N=20)
    assert r.status == "converged"
    # a new process finds the model in the cache and warns again
    code = "import warnings, pardel; warnings.simplefilter('always'); pardel.model(%r)" % str(path)
    done = subprocess.run([sys.executable, "-c", code], env=os.environ.copy(), capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stderr.count("ModelWarning: %s:4:5: warning: model 'fold_plane'" % path) == 1, done.stderr


def test_a_warning_made_an_error_is_raised_at_every_use(tmp_path):
    # With the "error" filter the warning is an exception; the model has then not been used, so a
    # second use raises it again rather than passing silently.
    path = tmp_path / "fold_again.lag"
    path.write_text(FOLD_LAG.replace("model fold_plane", "model fold_plane_again"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", pardel.ModelWarning)
        for _ in range(2):
            with pytest.raises(pardel.ModelWarning, match="fold_plane_again"):
                pardel.solve(path, q0=[0, 1], qN=[0.5, 1.5], T=1.0, N=20)


def test_a_regular_model_issues_no_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error", pardel.ModelWarning)
        calm = pardel.model("model calm_line\ncoords x\nL = x'^2/2 - x^2/2\n")
    assert calm.name == "calm_line"

"""A Python user's route through pardel, checked against docs/python.md: Ctrl-C during a batch and
a sweep (messages that name it, pardel.Interrupted with the partial result, problems never started
on their own grid), BatchResult indexed as its arrays are, the typing recipe for pardel.plot, the
refusal of an unknown model naming the function called, and docstrings and lists of the docs that
must match what the code writes."""
import csv
import json
import os
import pickle
import re
import signal
import subprocess
import threading
import typing

import numpy as np
import pytest

import pardel

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
FUEL_NAV_SCENE = os.path.join(ROOT, "scenes", "fuel_nav.toml")
ZERMELO_SWEEP = os.path.join(ROOT, "scenes", "sweeps", "zermelo_50.toml")
# x'' = -k x: a straight line for k = 0.
SPRING_WITH_K = "model spring_with_k\norder 1\ncoords x\nparam k = 1\nL = 1/2*x'^2 - 1/2*k*x^2\n"


def ctrl_c_after(seconds):
    """A timer that sends SIGINT to this process's main thread, as Ctrl-C does."""
    timer = threading.Timer(seconds, lambda: signal.pthread_kill(threading.main_thread().ident, signal.SIGINT))
    timer.start()
    return timer


def docs_python():
    with open(os.path.join(ROOT, "docs", "python.md"), encoding="utf-8") as f:
        return f.read()


# ---------------------------------------------------------------------------------------------
# Ctrl-C during a batch


def test_a_batch_stopped_by_ctrl_c_names_it_and_keeps_the_grid_of_problems_never_started():
    model = pardel.model("fuel_nav")  # loaded before the timer starts
    qN = np.array([6.0, 5.0]) + 0.1 * np.arange(6)[:, None]
    timer = ctrl_c_after(0.5)
    try:
        # One problem at a time by jacobi-newton, 10^8 sweeps each: hours unless stopped, so the
        # first problem is stopped mid-solve and the other five never start.
        with pytest.raises(KeyboardInterrupt) as info:
            pardel.solve_batch(model, q0=[0, 0], qN=qN, T=30, N=200, method="jacobi-newton",
                               max_iterations=100000000, threads=1)
    finally:
        timer.cancel()
    assert isinstance(info.value, pardel.Interrupted)
    b = info.value.result
    assert isinstance(b, pardel.BatchResult) and list(b.status) == ["interrupted"] * 6
    stopped = [r for r in b if r.iterations > 0]
    never = [r for r in b if r.iterations == 0]
    assert len(stopped) == 1 and len(never) == 5
    # A batch takes no on_iteration: the stopped solve's message names Ctrl-C, as pardel.solve's does.
    assert "on_iteration" not in stopped[0].message
    assert stopped[0].message.startswith("interrupted by Ctrl-C (KeyboardInterrupt) at iteration %d"
                                         % stopped[0].iterations)
    assert not stopped[0].stopped_by_callback
    for r in never:
        # Its initial guess, on the grid it was given: N agrees with the rows of q and t.
        assert r.message == "not started: the batch was interrupted"
        assert r.N == 200 and r.summary["N"] == 200
        assert r.q.shape == (r.N + 1, 2) and r.t.shape == (r.N + 1,)
        assert r.residual is None and r.action is None
        np.testing.assert_allclose(r.q[0], [0, 0])
    assert np.isnan(b.residual[1:]).all()


# ---------------------------------------------------------------------------------------------
# Ctrl-C during a sweep


def test_a_sweep_stopped_by_ctrl_c_raises_interrupted_with_the_sweep_so_far(tmp_path):
    pardel.model("zermelo")  # loaded before the timer starts
    out = tmp_path / "interrupted"
    timer = ctrl_c_after(1.0)
    try:
        # jacobi-newton with 10^8 sweeps per variant: some variants end, one runs until stopped.
        with pytest.raises(KeyboardInterrupt) as info:
            pardel.sweep(ZERMELO_SWEEP, ["solver.method=jacobi-newton", "solver.max_iterations=100000000"],
                         threads=1, out=out)
    finally:
        timer.cancel()
    assert isinstance(info.value, pardel.Interrupted) and info.value.checkpoint is None
    r = info.value.result
    assert isinstance(r, pardel.SweepResult) and r.out == str(out)
    statuses = [v.status for v in r.variants]
    assert 1 <= len(statuses) < 50 and statuses.count("interrupted") == 1 and statuses[-1] == "interrupted"
    assert r.summary["variants"] == 50 and r.summary["not_started"] == 50 - len(statuses)
    assert r.converged == statuses.count("converged")
    ended = len(statuses) - 1
    assert str(info.value).startswith("pardel.sweep: interrupted with %d of 50 variants ended (%d converged, %d not "
                                      "started)" % (ended, r.converged, 50 - len(statuses)))
    # The files written hold the same sweep.
    with open(out / "variants.csv") as f:
        assert [row["status"] for row in csv.DictReader(f)] == statuses
    assert json.loads((out / "sweep.json").read_text())["not_started"] == r.summary["not_started"]
    again = pickle.loads(pickle.dumps(info.value))
    assert isinstance(again, pardel.Interrupted) and [v.status for v in again.result.variants] == statuses


# ---------------------------------------------------------------------------------------------
# BatchResult indexing


@pytest.fixture(scope="module")
def batch():
    # Six problems with distinct targets: distinct iteration counts and costs to select by.
    qN = np.array([[6, 5], [1, 0.5], [4, 4], [6, 2], [2, 5], [3, 1]], dtype=float)
    return pardel.solve_batch("fuel_nav", q0=[0, 0], qN=qN, T=30, N=40, threads=2)


def same_part(part, b, key):
    """part is b's problems at key: the same Results, and the arrays indexed by key."""
    chosen = np.arange(len(b))[key]
    assert isinstance(part, pardel.BatchResult) and len(part) == len(chosen)
    assert all(p is b.results[i] for p, i in zip(part.results, chosen))
    for name in ("status", "converged", "iterations", "residual", "action", "cost", "t", "q"):
        mine, whole = getattr(part, name), getattr(b, name)
        assert mine.dtype == whole.dtype and mine.shape == whole[key].shape, name
        np.testing.assert_array_equal(mine, whole[key])
    assert part.threads == b.threads and part.wall_seconds == b.wall_seconds


def test_a_batch_result_is_indexed_as_its_arrays(batch):
    b = batch
    assert isinstance(b[2], pardel.Result) and b[2] is b.results[2] and b[-1] is b.results[-1]
    assert b[np.int64(3)] is b.results[3]
    for key in (slice(1, 4), slice(None, None, -2), slice(10, 20)):
        same_part(b[key], b, key)
    cheap = b.cost < np.median(b.cost)
    assert 0 < cheap.sum() < len(b)
    same_part(b[cheap], b, cheap)
    same_part(b[b.converged], b, b.converged)
    order = np.argsort(b.cost)
    same_part(b[order], b, order)
    same_part(b[[4, 0, 4]], b, [4, 0, 4])
    same_part(b[[]], b, np.array([], dtype=int))
    same_part(b[[True, False] * 3], b, np.array([True, False] * 3))
    assert [r.cost for r in b[order]] == sorted(b.cost.tolist())
    again = pickle.loads(pickle.dumps(b[1:3]))
    assert isinstance(again, pardel.BatchResult) and len(again) == 2
    np.testing.assert_array_equal(again.q, b.q[1:3])


@pytest.mark.parametrize("key", [1.0, "0", (0, 1), None, True, np.zeros((2, 2), dtype=int), np.array([0.5])])
def test_other_keys_of_a_batch_result_raise_a_type_error_naming_it(batch, key):
    with pytest.raises(TypeError, match=r"^pardel.BatchResult: an index must be an int, a slice, a boolean mask of "
                                        r"length 6, or a list or 1-D array of ints, got "):
        batch[key]


def test_a_mask_of_another_length_or_an_index_out_of_range_is_an_index_error(batch):
    with pytest.raises(IndexError, match=r"^pardel.BatchResult: "):
        batch[np.array([True, False])]
    with pytest.raises(IndexError, match=r"^pardel.BatchResult: "):
        batch[[0, 6]]


def test_a_problem_on_another_grid_is_all_nan_in_the_batch_arrays():
    # With accuracy the two problems end on different grids (a free particle's straight line is
    # exact on the first grid, a stiff spring's path is not); the batch's arrays are on the larger.
    b = pardel.solve_batch(SPRING_WITH_K, q0=[0], qN=[1], T=1, params={"k": np.array([0.0, 10.0])}, accuracy=1e-4,
                           threads=1)
    sizes = [r.N for r in b]
    assert b.converged.all() and sizes[0] != sizes[1]
    small, large = int(np.argmin(sizes)), int(np.argmax(sizes))
    assert b.q.shape == (2, max(sizes) + 1, 1) and b.t.shape == (2, max(sizes) + 1)
    assert np.isnan(b.q[small]).all() and np.isnan(b.t[small]).all()
    np.testing.assert_array_equal(b.q[large], b[large].q)
    assert b[small].q.shape == (min(sizes) + 1, 1) and np.isfinite(b[small].q).all()
    assert "are all NaN, not its rows padded" in " ".join(docs_python().split())


# ---------------------------------------------------------------------------------------------
# Typing, docstrings and the docs' lists


def test_the_documented_type_hints_recipe_resolves_every_annotated_function():
    # docs/python.md: get_type_hints(f, globalns=dict(f.__globals__, sympy=sympy, Axes=Axes)).
    sympy = pytest.importorskip("sympy")
    Axes = pytest.importorskip("matplotlib.axes").Axes
    for f in (pardel.plot.path, pardel.plot.coordinates, pardel.plot.convergence, pardel.model_from_sympy,
              pardel.solve, pardel.BatchResult.__getitem__):
        hints = typing.get_type_hints(f, globalns=dict(f.__globals__, sympy=sympy, Axes=Axes))
        assert "return" in hints, f.__qualname__
    assert typing.get_type_hints(pardel.plot.path, globalns=dict(pardel.plot.path.__globals__, Axes=Axes))[
        "result"] is pardel.Result


def test_check_docstring_names_only_what_check_json_leaves_out(tmp_path):
    cli = os.environ.get("PARDEL_CLI")
    if not cli:
        pytest.skip("PARDEL_CLI (the pardel command line) is not set")
    done = subprocess.run([cli, "check", FUEL_NAV_SCENE, "--json"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    written = json.loads(done.stdout)
    scene = pardel.load_scene(FUEL_NAV_SCENE)
    mine = pardel.check(scene)
    assert set(mine) == set(written)
    python_only = set(mine["certificate"]) - set(written["certificate"])
    assert python_only == {"report"}
    doc = " ".join(pardel.check.__doc__.split())
    claim = doc.split('"certificate" also holds', 1)[1]  # what it says --json leaves out
    for key in python_only:
        assert re.search(r"\b%s\b" % key, claim), key
    for key in written["certificate"]:
        assert not re.search(r"\b%s\b" % key, claim), "%s: --json writes it" % key


def test_docs_list_the_lag_functions_that_model_from_sympy_names():
    sympy = pytest.importorskip("sympy")
    t = sympy.Symbol("t")
    x = sympy.Function("x")(t)
    with pytest.raises(pardel.PardelError) as info:
        pardel.model_from_sympy(sympy.Abs(x.diff(t)), [x])
    refused = re.search(r"\(((?:[a-z0-9]+ )+[a-z0-9]+)\)", str(info.value)).group(1).split()
    assert "sin" in refused and "pow" in refused
    text = " ".join(docs_python().split())
    listed = re.search(r"a function other than `\.lag`'s `([a-z0-9 ]+)`", text).group(1).split()
    assert listed == refused


# ---------------------------------------------------------------------------------------------
# An unknown model


@pytest.mark.parametrize("where, call", [
    ("pardel.model", lambda: pardel.model(" fuel_nav")),
    ("pardel.model", lambda: pardel.Model("nonexist")),
    ("pardel.solve_batch", lambda: pardel.solve_batch("nonexist", q0=[0, 0], qN=[1, 1], T=1, N=4)),
    ("pardel.kernels", lambda: pardel.kernels("nonexist", "midpoint", 0.1, 0, 0.1, [0, 0], [0, 0])),
    ("pardel.solve", lambda: pardel.solve("nonexist", q0=[0, 0], qN=[1, 1], T=1, N=4)),
])
def test_an_unknown_model_is_refused_naming_the_function_called(where, call):
    with pytest.raises(pardel.ModelError, match=r"^%s: unknown model '.*' \(compiled models: .*fuel_nav"
                       % re.escape(where)):
        call()


def test_a_malformed_lag_file_keeps_the_generators_file_line_and_column(tmp_path):
    path = tmp_path / "typo.lag"
    path.write_text("model typo\norder 1\ncoords x\nL = 1/2*x'^2 - sinn(x)\n")
    with pytest.raises(pardel.ModelError) as info:
        pardel.model(str(path))
    assert str(info.value).startswith("%s:4:" % path)

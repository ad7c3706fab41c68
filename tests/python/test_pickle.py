"""Pickling: a Result and a BatchResult round-trip whole; a Model pickles as what it was built from
(a bundled name, a .lag path, .lag text, SymPy's printed text) and reloads in another process, with
another model cache, where it solves to the same numbers bit for bit."""
import math
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest

import pardel


def same_value(a, b):
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same_value(a[k], b[k]) for k in a)
    if isinstance(a, float) and math.isnan(a):
        return isinstance(b, float) and math.isnan(b)
    return type(a) is type(b) and a == b


def assert_same_result(a, b):
    assert type(a) is type(b) is pardel.Result
    assert a.__dict__.keys() == b.__dict__.keys()
    for key in a.__dict__:
        assert same_value(a.__dict__[key], b.__dict__[key]), key


def test_a_result_round_trips_whole(spring_lag):
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2, N=20)
    again = pickle.loads(pickle.dumps(r))
    assert_same_result(r, again)
    assert again.converged and repr(again) == repr(r)
    np.testing.assert_array_equal(again.coordinate("y"), r.coordinate("y"))
    # A result without an error estimate (NaN) and one stopped by the callback.
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2, N=20, error_estimate=False,
                     on_iteration=lambda *_: False)
    assert math.isnan(r.error_estimate) and r.stopped_by_callback
    assert_same_result(r, pickle.loads(pickle.dumps(r, protocol=2)))


def test_a_batch_result_round_trips_whole(spring_lag):
    b = pardel.solve_batch(spring_lag, q0=[0, 0], qN=[[1, 2], [2, 1], [0.5, 0.5]], T=2, N=20, threads=1)
    again = pickle.loads(pickle.dumps(b))
    assert len(again) == 3
    for name in ("status", "converged", "iterations", "residual", "action", "cost", "t", "q"):
        np.testing.assert_array_equal(getattr(again, name), getattr(b, name))
    for x, y in zip(b, again):
        assert_same_result(x, y)


def sympy_magnetic():
    sp = pytest.importorskip("sympy")
    t = sp.Symbol("t")
    x, y = sp.Function("x")(t), sp.Function("y")(t)
    B = sp.Symbol("B")
    L = (x.diff(t) ** 2 + y.diff(t) ** 2) / 2 + B / 2 * (x * y.diff(t) - y * x.diff(t))
    return pardel.model_from_sympy(L, [x, y], {B: 1.3}, name="pickled_charge")


def models(spring_lag, folder):
    path = folder / "spring.lag"
    path.write_text(spring_lag.replace("model aniso_spring", "model pickled_spring"))
    return {"bundled": pardel.model("harmonic"), "path": pardel.model(str(path)),
            "text": pardel.model(spring_lag), "sympy": sympy_magnetic()}


PROBLEMS = {"bundled": dict(q0=[0.0], qN=[1.0], T=1.0, N=16), "path": dict(q0=[0, 0], qN=[1, 2], T=2.0, N=16),
            "text": dict(q0=[0, 0], qN=[1, 2], T=2.0, N=16), "sympy": dict(q0=[0.5, -1], qN=[2, 1.5], T=2.0, N=16)}


def test_models_round_trip_in_this_process(spring_lag, tmp_path):
    for kind, model in models(spring_lag, tmp_path).items():
        again = pickle.loads(pickle.dumps(model))
        assert type(again) is pardel.Model
        for name in ("name", "spec", "lag_text", "order", "dim", "coords", "params", "discretizations",
                     "has_clock", "time_dependent"):
            assert getattr(again, name) == getattr(model, name), (kind, name)
        assert (model.lag_text is None) == (kind in ("bundled", "path"))
        r, s = pardel.solve(model, **PROBLEMS[kind]), pardel.solve(again, **PROBLEMS[kind])
        np.testing.assert_array_equal(r.q, s.q)


def test_a_pickled_path_model_reads_its_file_again(spring_lag, tmp_path):
    path = tmp_path / "spring.lag"
    path.write_text(spring_lag.replace("model aniso_spring", "model reread_spring"))
    data = pickle.dumps(pardel.model(str(path)))
    path.write_text(spring_lag.replace("model aniso_spring", "model reread_spring").replace("param a = 1.5",
                                                                                        "param a = 2.5"))
    assert pickle.loads(data).params == {"a": 2.5, "b": 0.7}


# Runs in a fresh interpreter: unpickles the models from stdin (SymPy is never imported: the SymPy
# model travels as its .lag text), solves each problem and pickles the results to stdout.
CHILD = r'''
import pickle, sys
import pardel
models, problems = pickle.loads(sys.stdin.buffer.read())
results = {kind: pardel.solve(model, **problems[kind]) for kind, model in models.items()}
assert "sympy" not in sys.modules
sys.stdout.buffer.write(pickle.dumps((results, {k: m.spec for k, m in models.items()})))
'''


def test_models_reload_in_another_process_with_another_cache(spring_lag, tmp_path):
    here = models(spring_lag, tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = dict(os.environ, PARDEL_CACHE_DIR=str(tmp_path / "child-cache"))
    done = subprocess.run([sys.executable, "-c", CHILD], input=pickle.dumps((here, PROBLEMS)), cwd=str(elsewhere),
                          env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=110)
    assert done.returncode == 0, done.stderr.decode()
    results, specs = pickle.loads(done.stdout)
    # The text models were written into the child's own cache, the others named as here.
    for kind in ("text", "sympy"):
        assert specs[kind].startswith(str(tmp_path / "child-cache")) and specs[kind] != here[kind].spec
    assert specs["bundled"] == "harmonic" and specs["path"] == here["path"].spec
    for kind, model in here.items():
        mine = pardel.solve(model, **PROBLEMS[kind])
        theirs = results[kind]
        assert theirs.converged, (kind, theirs.message)
        np.testing.assert_array_equal(theirs.q, mine.q)
        np.testing.assert_array_equal(theirs.p0, mine.p0)
        assert theirs.action == mine.action and theirs.iterations == mine.iterations

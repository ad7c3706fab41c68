"""Checkpoints and resume from Python: pardel.solve(..., checkpoint=FOLDER) and
pardel.solve_scene(..., checkpoint=FOLDER) write `pardel solve`'s checkpoint when a solve is
interrupted, pardel.resume(FOLDER) continues it to the iterates of an uninterrupted solve (checked
bit for bit, and against the exact solution of the discrete recursion), `pardel solve --resume`
continues it too, solver options given to pardel.resume make it the command line's warm start
(`--resume --set solver.KEY=VALUE`), and the partial result of an interrupted solve is the .result
of pardel.Interrupted. Damaged, foreign and mismatched checkpoints raise pardel.CheckpointError
naming the file."""
import json
import os
import pickle
import shutil
import signal
import subprocess
import threading

import numpy as np
import pytest

import pardel

A, B = 1.5, 0.7  # the spring's frequencies (conftest.py)
T = 1.0
N = 30
PROBLEM = dict(q0=[0, 0], qN=[1, 2], T=T, N=N, discretization="midpoint", threads=1, error_estimate=False, tol=1e-13)
# A nonlinear problem on which newton and hybrid take several iterations (17 and 990).
FUEL = dict(q0=[0, 0], qN=[6, 5], T=30, N=60, threads=1, error_estimate=False)


@pytest.fixture(scope="module")
def spring(spring_lag):
    return pardel.model(spring_lag)


def stop_at(k):
    """An on_iteration that stops the solve at iteration k."""
    return lambda iteration, n, residual, action: iteration < k


def assert_same_solve(resumed, full):
    """The resumed solve's answer and record are the uninterrupted one's, bit for bit (wall times aside)."""
    assert resumed.status == full.status
    assert resumed.iterations == full.iterations
    np.testing.assert_array_equal(resumed.q, full.q)
    np.testing.assert_array_equal(resumed.t, full.t)
    assert resumed.residual == full.residual and resumed.action == full.action
    for key in ("iteration", "N", "residual", "action"):
        np.testing.assert_array_equal(resumed.history[key], full.history[key])


def assert_exact(result, exact):
    np.testing.assert_allclose(result.q[:, 0], exact(A, T, N, 1.0, "midpoint"), rtol=0, atol=1e-10)
    np.testing.assert_allclose(result.q[:, 1], exact(B, T, N, 2.0, "midpoint"), rtol=0, atol=1e-10)


def test_resume_continues_to_the_uninterrupted_solve(spring, exact, tmp_path):
    full = pardel.solve(spring, method="jacobi-newton", **PROBLEM)
    assert full.status == "converged" and full.iterations > 1000
    assert_exact(full, exact)
    folder = tmp_path / "ck"
    stopped = pardel.solve(spring, method="jacobi-newton", on_iteration=stop_at(40), checkpoint=folder, **PROBLEM)
    assert stopped.status == "interrupted" and stopped.stopped_by_callback and stopped.iterations == 40
    assert stopped.checkpoint == str(folder)
    assert sorted(os.listdir(folder)) == ["checkpoint.json", "scene.toml"]
    resumed = pardel.resume(folder)
    assert_same_solve(resumed, full)
    assert_exact(resumed, exact)
    assert resumed.checkpoint is None
    # a finished solve leaves no checkpoint to resume twice
    assert not (folder / "checkpoint.json").exists()
    with pytest.raises(pardel.CheckpointError, match="checkpoint.json: error: cannot open"):
        pardel.resume(folder)


@pytest.mark.parametrize("method,k", [("newton", 5), ("hybrid", 400), ("jacobi-newton", 1000)])
def test_resume_of_a_nonlinear_problem(tmp_path, method, k):
    full = pardel.solve("fuel_nav", method=method, **FUEL)
    assert full.status == "converged" and full.iterations > k
    folder = tmp_path / "ck"
    stopped = pardel.solve("fuel_nav", method=method, on_iteration=stop_at(k), checkpoint=folder, **FUEL)
    assert stopped.status == "interrupted" and stopped.stopped_by_callback and stopped.iterations == k
    assert stopped.checkpoint == str(folder)
    assert sorted(os.listdir(folder)) == ["checkpoint.json", "scene.toml"]
    resumed = pardel.resume(folder)
    assert_same_solve(resumed, full)
    assert resumed.cost == full.cost and resumed.point == full.point
    assert not (folder / "checkpoint.json").exists()


def test_resume_interrupted_again_and_resumed_again(spring, tmp_path):
    full = pardel.solve(spring, method="jacobi-newton", **PROBLEM)
    folder = str(tmp_path / "ck")
    pardel.solve(spring, method="jacobi-newton", on_iteration=stop_at(25), checkpoint=folder, **PROBLEM)
    again = pardel.resume(folder, on_iteration=stop_at(60))
    assert again.status == "interrupted" and again.iterations == 60 and again.checkpoint == folder
    np.testing.assert_array_equal(again.history["iteration"], full.history["iteration"][:61])
    np.testing.assert_array_equal(again.history["residual"], full.history["residual"][:61])
    assert_same_solve(pardel.resume(folder, threads=2), full)


def test_scene_file_with_overrides(spring_lag, exact, tmp_path):
    lag = tmp_path / "spring.lag"
    lag.write_text(spring_lag)
    scene_file = tmp_path / "spring.toml"
    scene_file.write_text('model = "spring.lag"\ndiscretization = "midpoint"\n[grid]\nT = 1.0\nN = 8\n'
                          '[boundary]\nq0 = [0, 0]\nqN = [1, 2]\n[solver]\nmethod = "jacobi-newton"\n'
                          'error_estimate = false\ntol = 1e-13\n')
    scene = pardel.load_scene(scene_file, ["grid.N=%d" % N])
    full = pardel.solve_scene(scene, threads=1)
    assert_exact(full, exact)
    folder = tmp_path / "out"
    stopped = pardel.solve_scene(scene, threads=1, on_iteration=stop_at(30), checkpoint=folder)
    assert stopped.iterations == 30 and stopped.checkpoint == str(folder)
    assert os.listdir(folder) == ["checkpoint.json"]  # the scene is the file, recorded by its path
    body = json.loads((folder / "checkpoint.json").read_text())["body"]
    assert body["scene"]["path"] == str(scene_file)
    assert body["scene"]["overrides"] == ["grid.N=%d" % N] and body["scene"]["threads"] == 1
    assert_same_solve(pardel.resume(folder), full)


def test_keyboard_interrupt_from_the_callback_carries_the_partial_result(spring, tmp_path):
    def interrupt(iteration, n, residual, action):
        if iteration == 12:
            raise KeyboardInterrupt

    folder = tmp_path / "ck"
    with pytest.raises(pardel.Interrupted) as caught:
        pardel.solve(spring, method="jacobi-newton", on_iteration=interrupt, checkpoint=folder, **PROBLEM)
    error = caught.value
    assert isinstance(error, KeyboardInterrupt)
    assert error.result.status == "interrupted" and error.result.iterations == 12
    assert not error.result.stopped_by_callback
    assert error.result.q.shape == (N + 1, 2) and error.checkpoint == str(folder) == error.result.checkpoint
    assert str(error).startswith("pardel.solve: interrupted at iteration 12 (status interrupted, residual ")
    assert str(error).endswith("continue with pardel.resume(%r)" % str(folder))
    # the last iterate is the twelfth iterate of the same solve stopped there by the callback
    reference = pardel.solve(spring, method="jacobi-newton", on_iteration=stop_at(12), **PROBLEM)
    np.testing.assert_array_equal(error.result.q, reference.q)
    assert error.result.residual == reference.residual == reference.history["residual"][-1]
    copy = pickle.loads(pickle.dumps(error))
    assert isinstance(copy, pardel.Interrupted) and str(copy) == str(error)
    np.testing.assert_array_equal(copy.result.q, error.result.q)
    # without a checkpoint: the same partial result, no checkpoint named
    with pytest.raises(pardel.Interrupted) as caught:
        pardel.solve(spring, method="jacobi-newton", on_iteration=interrupt, **PROBLEM)
    assert caught.value.checkpoint is None and "pardel.resume" not in str(caught.value)
    np.testing.assert_array_equal(caught.value.result.q, reference.q)


def test_other_exceptions_of_the_callback_are_raised_as_they_are(spring, tmp_path):
    full = pardel.solve(spring, method="jacobi-newton", **PROBLEM)

    def fail(iteration, n, residual, action):
        if iteration == 9:
            raise ZeroDivisionError("callback failed at 9")

    folder = tmp_path / "ck"
    with pytest.raises(ZeroDivisionError, match="callback failed at 9"):
        pardel.solve(spring, method="jacobi-newton", on_iteration=fail, checkpoint=folder, **PROBLEM)
    assert_same_solve(pardel.resume(folder), full)  # the checkpoint was written all the same


def test_sigint_raises_interrupted_and_the_checkpoint_resumes(spring, tmp_path):
    # jacobi-newton, N = 400, 10^8 sweeps: hours unless stopped.
    long = dict(q0=[0, 0], qN=[1, 2], T=2.0, N=400, method="jacobi-newton", max_iterations=100000000, threads=1)
    folder = tmp_path / "ck"
    timer = threading.Timer(0.5, lambda: signal.pthread_kill(threading.main_thread().ident, signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(pardel.Interrupted) as caught:
            pardel.solve(spring, checkpoint=folder, **long)
    finally:
        timer.cancel()
    partial = caught.value.result
    assert partial.status == "interrupted" and partial.iterations > 0 and partial.q.shape == (401, 2)
    assert partial.iterations == partial.history["iteration"][-1]
    assert caught.value.checkpoint == str(folder) and (folder / "checkpoint.json").is_file()
    k = partial.iterations + 50
    resumed = pardel.resume(folder, on_iteration=stop_at(k))
    straight = pardel.solve(spring, on_iteration=stop_at(k), **long)
    # on_iteration sees the recorded iterations alone (further apart as the count grows): both stop
    # at the first one from k on
    assert resumed.iterations == straight.iterations >= k
    np.testing.assert_array_equal(resumed.q, straight.q)
    np.testing.assert_array_equal(resumed.history["residual"], straight.history["residual"])


def test_a_finished_solve_removes_the_checkpoint(spring, tmp_path):
    folder = tmp_path / "ck"
    pardel.solve(spring, method="jacobi-newton", on_iteration=stop_at(5), checkpoint=folder, **PROBLEM)
    assert (folder / "checkpoint.json").is_file()
    limited = pardel.solve(spring, method="jacobi-newton", checkpoint=folder, max_iterations=20, **PROBLEM)
    assert limited.status == "max_iterations" and limited.checkpoint is None
    assert not (folder / "checkpoint.json").exists()


@pytest.mark.skipif(not os.environ.get("PARDEL_CLI"), reason="the command line is not built")
def test_the_command_line_resumes_a_checkpoint_of_python(tmp_path):
    full = pardel.solve("fuel_nav", method="newton", **FUEL)
    folder = tmp_path / "ck"
    pardel.solve("fuel_nav", method="newton", on_iteration=stop_at(5), checkpoint=folder, **FUEL)
    run = subprocess.run([os.environ["PARDEL_CLI"], "solve", "--resume", str(folder), "--quiet", "--no-plot"],
                         capture_output=True, text=True, timeout=100)
    assert run.returncode == 0, run.stderr
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["status"] == "converged" and summary["iterations"] == full.iterations
    assert summary["residual"] == full.residual and summary["action"] == full.action
    rows = np.loadtxt(folder / "trajectory.csv", delimiter=",", skiprows=1)  # k, t, x, y, x', y'
    np.testing.assert_array_equal(rows[:, 1], full.t)
    np.testing.assert_array_equal(rows[:, 2:4], full.q)
    assert not (folder / "checkpoint.json").exists()


@pytest.mark.skipif(not os.environ.get("PARDEL_CLI"), reason="the command line is not built")
def test_python_resumes_a_checkpoint_of_the_command_line(tmp_path):
    # fuel_nav by jacobi-newton on N = 1000 to tol 1e-14: minutes unless stopped.
    scene_file = tmp_path / "fuel.toml"
    scene_file.write_text('model = "fuel_nav"\n[grid]\nT = 30.0\nN = 1000\n[boundary]\nq0 = [0, 0]\n'
                          'qN = [6, 5]\n[solver]\nmethod = "jacobi-newton"\ntol = 1e-14\nthreads = 1\n'
                          'error_estimate = false\n')
    out = tmp_path / "out"
    cli = subprocess.Popen([os.environ["PARDEL_CLI"], "solve", str(scene_file), "--out", str(out), "--quiet",
                            "--no-plot"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        while not out.exists() and cli.poll() is None:  # the folder is made just before the solve starts
            threading.Event().wait(0.05)
        threading.Event().wait(0.5)
        cli.send_signal(signal.SIGINT)
        _, stderr = cli.communicate(timeout=100)
    finally:
        if cli.poll() is None:
            cli.kill()
            cli.wait()
    assert cli.returncode == 6, stderr  # interrupted, checkpoint written
    stopped_at = json.loads((out / "summary.json").read_text())["iterations"]
    k = stopped_at + 20
    resumed = pardel.resume(out, on_iteration=stop_at(k))
    straight = pardel.solve_scene(pardel.load_scene(scene_file), on_iteration=stop_at(k))
    assert resumed.status == straight.status == "interrupted"
    assert resumed.iterations == straight.iterations >= k
    np.testing.assert_array_equal(resumed.q, straight.q)
    np.testing.assert_array_equal(resumed.history["residual"], straight.history["residual"])
    assert resumed.checkpoint == str(out) and (out / "checkpoint.json").is_file()


# --- warm starts: the recorded problem from the recorded iterate with other solver options ------

@pytest.fixture
def sweeps_stopped(tmp_path):
    """A folder holding the checkpoint of fuel_nav by jacobi-newton interrupted at iteration 50."""
    folder = tmp_path / "ck"
    stopped = pardel.solve("fuel_nav", method="jacobi-newton", on_iteration=stop_at(50), checkpoint=folder, **FUEL)
    assert stopped.status == "interrupted" and stopped.iterations == 50
    return folder


def test_warm_start_with_another_method_reaches_the_same_minimum(sweeps_stopped, tmp_path):
    cold = pardel.solve("fuel_nav", method="newton", **FUEL)
    copy = tmp_path / "copy"
    shutil.copytree(sweeps_stopped, copy)
    warm = pardel.resume(sweeps_stopped, method="newton", rtol=1e-12)
    assert warm.status == "converged" and warm.point["kind"] == "minimum"
    np.testing.assert_allclose(warm.q, cold.q, rtol=0, atol=1e-8)
    assert warm.cost == pytest.approx(cold.cost, rel=1e-12)
    assert not (sweeps_stopped / "checkpoint.json").exists()
    if os.environ.get("PARDEL_CLI"):  # the command line's warm start from the same checkpoint
        run = subprocess.run([os.environ["PARDEL_CLI"], "solve", "--resume", str(copy), "--set", "solver.method=newton",
                              "--set", "solver.rtol=1e-12", "--quiet", "--no-plot"],
                             capture_output=True, text=True, timeout=100)
        assert run.returncode == 0, run.stderr
        summary = json.loads((copy / "summary.json").read_text())
        assert summary["iterations"] == warm.iterations and summary["residual"] == warm.residual
        rows = np.loadtxt(copy / "trajectory.csv", delimiter=",", skiprows=1)  # k, t, x, y, x', y'
        np.testing.assert_array_equal(rows[:, 2:4], warm.q)


def test_a_warm_start_interrupted_again_records_its_options(sweeps_stopped, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(sweeps_stopped, copy)
    straight = pardel.resume(copy, method="newton")
    stopped = pardel.resume(sweeps_stopped, method="newton", on_iteration=stop_at(53))
    assert stopped.status == "interrupted" and stopped.checkpoint == str(sweeps_stopped)
    assert "solver.method=" in (sweeps_stopped / "checkpoint.json").read_text()
    resumed = pardel.resume(sweeps_stopped)  # newton again, as recorded
    assert_same_solve(resumed, straight)


@pytest.mark.parametrize("options,error,match", [
    (dict(T=5.0), pardel.PardelError, "^pardel.resume: T: changes the problem"),
    (dict(N=100), pardel.PardelError, "^pardel.resume: N: changes the problem"),
    (dict(q0=[1, 1]), pardel.PardelError, "^pardel.resume: q0: changes the problem"),
    (dict(params={"wind": 1.0}), pardel.PardelError, "^pardel.resume: params: changes the problem"),
    (dict(methd="newton"), pardel.PardelError, "^pardel.resume: unknown option 'methd'; did you mean 'method'"),
    (dict(rtol="tight"), TypeError, "pardel.resume: rtol must be a number"),
    (dict(method="newtn"), pardel.SceneError, "newtn"),
])
def test_a_warm_start_refuses_what_changes_the_problem(sweeps_stopped, options, error, match):
    with pytest.raises(error, match=match):
        pardel.resume(sweeps_stopped, **options)
    assert (sweeps_stopped / "checkpoint.json").is_file()  # the refusal leaves the checkpoint


# --- hostile checkpoints -------------------------------------------------------------------------

@pytest.fixture
def written(spring, tmp_path):
    """A folder holding the checkpoint of a solve interrupted at iteration 5."""
    folder = tmp_path / "ck"
    pardel.solve(spring, method="jacobi-newton", on_iteration=stop_at(5), checkpoint=folder, **PROBLEM)
    return folder


def resume_error(folder):
    with pytest.raises(pardel.CheckpointError) as caught:
        pardel.resume(folder)
    message = str(caught.value)
    assert message.startswith(os.path.join(str(folder), "checkpoint.json") + ": error: "), message
    return message


def test_missing_checkpoints(tmp_path):
    assert "cannot open" in resume_error(tmp_path / "nowhere")
    assert "cannot open" in resume_error(tmp_path)  # a folder without one
    (tmp_path / "file").write_text("x")
    resume_error(tmp_path / "file")  # a file where the folder should be
    (tmp_path / "dir" / "checkpoint.json").mkdir(parents=True)
    assert "is a directory" in resume_error(tmp_path / "dir")


@pytest.mark.parametrize("damage,what", [
    (lambda text: "", "JSON parse error"),
    (lambda text: text[: len(text) // 2], "JSON parse error"),
    (lambda text: "garbage\n", "JSON parse error"),
    (lambda text: "[" * 100000 + "]" * 100000, "nested more than"),
    (lambda text: json.dumps({"format": "something else"}), "not a pardel checkpoint"),
    (lambda text: text.replace('"version": 1', '"version": 99', 1), "version 99 is not supported"),
    (lambda text: text.replace('"iteration":5', '"iteration":6', 1), "checksum mismatch"),
])
def test_damaged_checkpoints(written, damage, what):
    path = written / "checkpoint.json"
    path.write_text(damage(path.read_text()))
    assert what in resume_error(written)


def test_checkpoint_of_a_changed_scene(written):
    scene = written / "scene.toml"
    scene.write_text(scene.read_text().replace("N = 30", "N = 31"))
    assert "the scene file %s changed since the checkpoint was written" % scene in resume_error(written)


def test_checkpoint_of_another_model(spring_lag, tmp_path):
    lag = tmp_path / "spring.lag"
    lag.write_text(spring_lag)
    folder = tmp_path / "ck"
    pardel.solve(str(lag), method="jacobi-newton", on_iteration=stop_at(5), checkpoint=folder, **PROBLEM)
    scene = (folder / "scene.toml").read_text()
    assert "model = '%s'" % lag in scene
    lag.write_text(spring_lag.replace("param b = 0.7", "param b = 0.8"))
    message = resume_error(folder)
    assert "the model aniso_spring changed since the checkpoint was written (its file" in message
    assert "was edited" in message


def fnv1a(data):
    """FNV-1a 64 of bytes as 16 hex digits (the checksum of a checkpoint's body)."""
    h = 14695981039346656037
    for byte in data:
        h = ((h ^ byte) * 1099511628211) % 2**64
    return "%016x" % h


def compact(body):
    return json.dumps(body, separators=(",", ":"), sort_keys=True, ensure_ascii=False).encode()


def test_checkpoint_whose_state_does_not_fit_its_scene(written):
    # A well-formed checkpoint (its checksum made again) whose state is of another method than its scene's.
    path = written / "checkpoint.json"
    checkpoint = json.loads(path.read_text())
    assert fnv1a(compact(checkpoint["body"])) == checkpoint["checksum"]
    assert checkpoint["body"]["state"]["method"] == "jacobi-newton"
    checkpoint["body"]["state"]["method"] = "newton"
    checkpoint["checksum"] = fnv1a(compact(checkpoint["body"]))
    path.write_text(json.dumps(checkpoint))
    assert ": error: resume: " in resume_error(written)
    assert (written / "checkpoint.json").is_file()  # refused, not removed


def test_an_adaptive_solve_takes_no_checkpoint(tmp_path):
    with pytest.raises(pardel.CheckpointError, match=r"an adaptive solve \(accuracy\) cannot be resumed"):
        pardel.solve("fuel_nav", q0=[0, 0], qN=[6, 5], T=30, accuracy=1e-6, checkpoint=tmp_path / "ck")
    assert not (tmp_path / "ck").exists()


def test_checkpoint_folder_that_cannot_be_made(spring, tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(pardel.CheckpointError, match="cannot create the checkpoint folder"):
        pardel.solve(spring, checkpoint=tmp_path / "file" / "ck", **PROBLEM)


def test_checkpoint_argument_types(spring, tmp_path):
    with pytest.raises(TypeError, match="pardel.solve: checkpoint must be a path"):
        pardel.solve(spring, checkpoint=3, **PROBLEM)
    with pytest.raises(pardel.PardelError, match="pardel.solve: checkpoint must name a folder"):
        pardel.solve(spring, checkpoint="", **PROBLEM)
    with pytest.raises(TypeError, match="pardel.resume: path must be a path"):
        pardel.resume(None)
    with pytest.raises(TypeError, match="pardel.resume: on_iteration must be callable"):
        pardel.resume(tmp_path, on_iteration=1)
    with pytest.raises(pardel.PardelError, match="refine_settle .* needs refine_start_N"):
        pardel.solve(spring, checkpoint=tmp_path / "ck", refine_settle=0.01, **PROBLEM)
    assert issubclass(pardel.CheckpointError, pardel.PardelError)

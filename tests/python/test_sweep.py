"""pardel.sweep: a sweep file run from Python gives what `pardel sweep` writes for the same file
(sweep.json, solutions.csv, variants.csv, the solution trajectories), and the answers of a
harmonic oscillator swept over its frequency match its closed-form solution; bad sweep files raise
the command line's message, and Ctrl-C stops a sweep with KeyboardInterrupt."""
import csv
import json
import math
import os
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import pardel

# x'' = -w^2 x; no bundled model is a one-dimensional oscillator.
OSCILLATOR_LAG = """\
# harmonic oscillator: x'' = -w^2 x
model sweep_oscillator
order 1
coords x
param w = 1
L = 1/2*x'^2 - 1/2*w^2*x^2
discretizations trapezoid midpoint
"""

X0, XT, T, N = 0.5, 1.0, 1.0, 100
FREQUENCIES = [1.0, 2.0, 2.5]

SCENE = """\
model = "oscillator.lag"
discretization = "trapezoid"

[grid]
T = %g
N = %d

[boundary]
q0 = [%g]
qN = [%g]

[solver]
rtol = 1e-12
""" % (T, N, X0, XT)

SWEEP = """\
scene = "oscillator.toml"
set = ["solver.method=newton"]

[[guesses]]
points = [[0], [3], [0]]

[[guesses]]
points = [[0], [-2], [1], [0]]

[random_guesses]
count = 3
seed = 7
spread = 2

[[vary]]
key = "params.w"
values = %s
""" % json.dumps(FREQUENCIES)


@pytest.fixture(scope="module")
def sweep_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sweep")
    (folder / "oscillator.lag").write_text(OSCILLATOR_LAG)
    (folder / "oscillator.toml").write_text(SCENE)
    (folder / "oscillator_sweep.toml").write_text(SWEEP)
    return folder / "oscillator_sweep.toml"


@pytest.fixture(scope="module")
def result(sweep_file, tmp_path_factory):
    return pardel.sweep(sweep_file, threads=1, out=tmp_path_factory.mktemp("python_out"))


@pytest.fixture(scope="module")
def cli_out(sweep_file, tmp_path_factory):
    cli = os.environ.get("PARDEL_CLI")
    if not cli:
        pytest.skip("PARDEL_CLI (the pardel command line) is not set")
    out = tmp_path_factory.mktemp("cli_out")
    done = subprocess.run([cli, "sweep", str(sweep_file), "--out", str(out), "--threads", "1", "--quiet",
                           "--no-plot"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return out


def continuous(w, t):
    """x(t) = A sin(wt) + B cos(wt) with x(0) = X0, x(T) = XT."""
    b = X0
    a = (XT - X0 * math.cos(w * T)) / math.sin(w * T)
    return a * np.sin(w * t) + b * np.cos(w * t), a * w * np.cos(w * t) - b * w * np.sin(w * t)


def discrete(w):
    """The exact solution of the trapezoid DEL recursion x_{k+1} + x_{k-1} = (2 - h^2 w^2) x_k."""
    h = T / N
    theta = math.acos(1 - (h * w) ** 2 / 2)
    k = np.arange(N + 1)
    a = (XT - X0 * math.cos(theta * N)) / math.sin(theta * N)
    return a * np.sin(theta * k) + X0 * np.cos(theta * k)


def trapezoid_action(w, x):
    h = T / N
    v = np.diff(x) / h
    return float(np.sum(h * (v ** 2 / 2 - w ** 2 * (x[:-1] ** 2 + x[1:] ** 2) / 4)))


def test_every_variant_reaches_the_unique_solution(result):
    guesses = 2 + 3
    assert len(result.variants) == len(FREQUENCIES) * guesses
    assert result.converged == len(result.variants) and result.failures == {}
    assert [v.id for v in result.variants] == list(range(len(result.variants)))
    # wT < pi: one solution per frequency, a minimum, reached from every guess
    assert len(result.solutions) == len(FREQUENCIES)
    for c, (w, s) in enumerate(zip(FREQUENCIES, result.solutions)):
        assert s.configuration == c and s.rank == 1 and s.certificate == "minimum"
        assert s.variants == list(range(c * guesses, (c + 1) * guesses))
        assert result.configurations[c]["params"]["w"] == w
        assert all(result.variants[i].solution == s.id for i in s.variants)
        assert all(list(result.variants[i].values) == ["params.w"] and float(result.variants[i].values["params.w"]) == w
                   for i in s.variants)


def test_answers_match_the_closed_form(result):
    assert result.cost_name == "action"
    for w, s in zip(FREQUENCIES, result.solutions):
        x = s.q[:, 0]
        assert s.t.shape == (N + 1,) and s.q.shape == (N + 1, 1)
        np.testing.assert_allclose(s.t, np.linspace(0, T, N + 1), rtol=0, atol=1e-14)
        # the DEL recursion's exact solution, and the continuous one to O(h^2)
        np.testing.assert_allclose(x, discrete(w), rtol=0, atol=1e-9)
        exact, velocity = continuous(w, s.t)
        np.testing.assert_allclose(x, exact, rtol=0, atol=1e-4 * w ** 2)
        assert s.cost == pytest.approx(trapezoid_action(w, x), rel=1e-12)
        # S = [x x'/2] from 0 to T on the continuous solution
        assert s.cost == pytest.approx((exact[-1] * velocity[-1] - exact[0] * velocity[0]) / 2, rel=1e-3)
        for i in s.variants:
            np.testing.assert_allclose(result.variants[i].q, s.q, rtol=0, atol=1e-4)
    assert result.best is result.solutions[int(np.argmin([s.cost for s in result.solutions]))]


def test_guesses_are_the_sweep_files(result):
    first = result.variants[:5]
    assert [v.guess for v in first] == ["listed 0", "listed 1", "random 0", "random 1", "random 2"]
    # listed polylines as the file gives them (their ends are replaced by the boundary when solved)
    assert first[0].guess_points == [[0.0], [3.0], [0.0]]
    assert first[1].guess_points == [[0.0], [-2.0], [1.0], [0.0]]
    for v in first[2:]:
        assert len(v.guess_points) == 4 and v.guess_points[0] == [X0] and v.guess_points[-1] == [XT]
    # the same guesses for every configuration
    assert [v.guess_points for v in result.variants[5:10]] == [v.guess_points for v in first]


def test_result_matches_pardel_sweep(result, cli_out):
    cli = json.loads((cli_out / "sweep.json").read_text())
    mine = result.summary
    for key in ("sweep", "scene", "model", "discretization", "cost", "set", "variants", "guesses_per_configuration",
                "configurations", "grouping", "converged", "failures", "solutions_count", "solutions", "best"):
        assert mine[key] == cli[key], key
    assert [(s["id"], s["cost"], s["variants"], s["first_variant"], s["certificate"]) for s in cli["solutions"]] == \
        [(s.id, s.cost, len(s.variants), s.first_variant, s.certificate) for s in result.solutions]
    for s in result.solutions:
        with open(cli_out / ("solution_%d.csv" % s.id)) as f:
            rows = list(csv.DictReader(f))
        assert np.array_equal([float(r["x"]) for r in rows], s.q[:, 0])
        assert np.array_equal([float(r["t"]) for r in rows], s.t)
    with open(cli_out / "variants.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(result.variants)
    for row, v in zip(rows, result.variants):
        assert int(row["variant"]) == v.id and row["status"] == v.status and int(row["iterations"]) == v.iterations
        assert float(row["cost"]) == v.cost and float(row["residual"]) == v.residual
        assert row["guess"] == v.guess and int(row["solution"]) == v.solution


def test_written_files_match_pardel_sweep(result, cli_out):
    out = result.out
    assert (cli_out / "solutions.csv").read_text() == open(os.path.join(out, "solutions.csv")).read()
    for s in result.solutions:
        name = "solution_%d.csv" % s.id
        assert (cli_out / name).read_text() == open(os.path.join(out, name)).read()

    def without_seconds(text):
        return [line.rsplit(",", 1)[0] for line in text.splitlines()]

    assert without_seconds((cli_out / "variants.csv").read_text()) == \
        without_seconds(open(os.path.join(out, "variants.csv")).read())


def test_overrides_apply_to_every_variant(sweep_file):
    r = pardel.sweep(sweep_file, ["grid.N=50"], threads=1)
    assert r.out is None
    assert all(c["N"] == 50 for c in r.configurations)
    assert all(v.q.shape == (51, 1) for v in r.variants)


def test_threads_zero_is_all_cores_as_on_the_command_line(sweep_file, tmp_path):
    # The scene asks for one thread; threads=0 overrides it with all cores, as `--threads 0` does,
    # and the answers are those of one thread (any thread count gives the same bits).
    one = pardel.sweep(sweep_file, ["solver.threads=1"])
    every = pardel.sweep(sweep_file, ["solver.threads=1"], threads=0, out=tmp_path / "all")
    assert json.loads((tmp_path / "all" / "sweep.json").read_text())["threads"] == 0
    assert [v.q.tolist() for v in every.variants] == [v.q.tolist() for v in one.variants]


def test_failed_variants_keep_no_trajectory(sweep_file):
    r = pardel.sweep(sweep_file, ["solver.method=jacobi-newton", "solver.max_iterations=1"], threads=1)
    assert r.converged == 0 and r.failures == {"max_iterations": 15}
    assert r.solutions == [] and r.best is None and r.summary["best"] is None
    for v in r.variants:
        assert v.status == "max_iterations" and v.iterations == 1
        assert v.t is None and v.q is None and v.solution is None and v.certificate is None


def test_errors_carry_the_command_lines_message(sweep_file, tmp_path):
    bad = tmp_path / "bad.toml"
    text = SWEEP.replace("scene = \"oscillator.toml\"", "scene = \"%s\"" % (sweep_file.parent / "oscillator.toml"))
    text = text.replace("count = 3", "cout = 3")
    bad.write_text(text)
    with pytest.raises(pardel.SceneError) as error:
        pardel.sweep(bad)
    message = str(error.value)
    line = text.splitlines().index("cout = 3") + 1
    assert message.startswith("%s:%d:1: error: unknown key 'random_guesses.cout'; did you mean 'random_guesses.count'?"
                              % (bad, line))
    cli = os.environ.get("PARDEL_CLI")
    if cli:
        done = subprocess.run([cli, "sweep", str(bad), "--quiet", "--no-plot"], capture_output=True, text=True)
        assert done.returncode == 2 and done.stderr.strip() == message.strip()
    with pytest.raises(pardel.SceneError, match="--set grid.N=0: error"):
        pardel.sweep(sweep_file, ["grid.N=0"])
    with pytest.raises(pardel.SceneError, match="no_such_sweep.toml"):
        pardel.sweep(tmp_path / "no_such_sweep.toml")


def test_ctrl_c_stops_a_sweep(sweep_file, tmp_path):
    # The timer thread needs the GIL to send the signal: the sweep must have released it.
    pardel.model(str(sweep_file.parent / "oscillator.lag"))  # compiled before the timer starts
    timer = threading.Timer(0.5, lambda: signal.pthread_kill(threading.main_thread().ident, signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        # jacobi-newton with 10^8 sweeps per variant: hours unless stopped
        with pytest.raises(KeyboardInterrupt):
            pardel.sweep(sweep_file, ["solver.method=jacobi-newton", "solver.max_iterations=100000000", "grid.N=400"],
                         threads=1, out=tmp_path / "interrupted")
    finally:
        timer.cancel()
    assert time.monotonic() - start < 30
    # the variants started are listed (stopped mid-solve), the others counted in sweep.json
    with open(tmp_path / "interrupted" / "variants.csv") as f:
        statuses = [row["status"] for row in csv.DictReader(f)]
    assert 1 <= len(statuses) < 15 and set(statuses) == {"interrupted"}
    summary = json.loads((tmp_path / "interrupted" / "sweep.json").read_text())
    assert summary["variants"] == 15 and summary["not_started"] == 15 - len(statuses)

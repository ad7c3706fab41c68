"""pardel.solve_batch on barrier_channel (tests/runtime/models: a particle in the channel |x| < 1
under a constant force, held off the walls by a logarithmic barrier of weight w): every entry is
pardel.solve's answer for that problem, bit for bit, with one or two threads; an entry without
barrier is the exact parabola; converged, max_iterations and non_finite problems in one batch;
broadcasting; and errors that name the argument."""
import os

import numpy as np
import pytest

import pardel

MODEL = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "runtime", "models", "barrier_channel.lag")
T, N = 2.0, 50


def varied(B=6, seed=3):
    rng = np.random.default_rng(seed)
    q0 = np.column_stack([rng.uniform(-0.6, 0.6, B), rng.uniform(-1, 1, B)])
    qN = np.column_stack([rng.uniform(-0.6, 0.6, B), rng.uniform(-1, 1, B)])
    params = {"gx": rng.uniform(-1, 1, B), "gy": rng.uniform(-2, 0, B), "w": rng.uniform(0, 0.4, B)}
    # Guesses on 33 nodes (resampled to N + 1 = 51): the straight line with a bump in y.
    s = np.linspace(0, 1, 33)[None, :, None]
    guess = q0[:, None, :] * (1 - s) + qN[:, None, :] * s
    guess[:, :, 1] += 0.5 * np.sin(np.pi * s[:, :, 0])
    return q0, qN, params, guess


def same(a, b):
    """Bit for bit (NaN where NaN)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("threads", [1, 2])
def test_every_entry_is_the_solve_alone(threads):
    q0, qN, params, guess = varied()
    batch = pardel.solve_batch(MODEL, q0=q0, qN=qN, T=T, N=N, params=params, guess=guess, threads=threads)
    assert isinstance(batch, pardel.BatchResult)
    assert len(batch) == 6 and batch.threads == threads
    assert batch.q.shape == (6, N + 1, 2) and batch.t.shape == (6, N + 1)
    assert batch.converged.all()
    for i, r in enumerate(batch):
        alone = pardel.solve(MODEL, q0=q0[i], qN=qN[i], T=T, N=N, guess=guess[i], threads=1,
                             params={k: v[i] for k, v in params.items()})
        assert r.status == alone.status == "converged"
        assert r.iterations == alone.iterations
        assert same(r.q, alone.q) and same(batch.q[i], alone.q) and same(r.t, alone.t)
        assert same(r.residual, alone.residual) and same(r.action, alone.action)
        assert same(r.error_estimate, alone.error_estimate)
        assert same(r.p0, alone.p0) and same(r.pN, alone.pN)
        assert r.point == alone.point and r.point["kind"] == "minimum"
        assert same(r.history["residual"], alone.history["residual"])


def test_entry_without_barrier_is_the_exact_parabola():
    # w = 0: x'' = gx, y'' = gy, whose parabolas the trapezoid rule reproduces at the nodes.
    g = np.array([0.5, -1.25])
    q0, qN = np.array([[0.1, 0.2], [-0.3, 0.5]]), np.array([[0.4, -0.6], [0.2, 0.1]])
    batch = pardel.solve_batch(MODEL, q0=q0, qN=qN, T=T, N=N, params={"gx": g[0], "gy": g[1], "w": [0.0, 0.3]})
    assert list(batch.status) == ["converged", "converged"]
    t = batch.t[0][:, None]
    exact = q0[0] + (qN[0] - q0[0] - g * T * T / 2) * t / T + g * t * t / 2
    np.testing.assert_allclose(batch.q[0], exact, rtol=0, atol=1e-12)
    assert np.abs(batch.q[1] - batch.q[0]).max() > 1e-3  # the barrier moves the other one


def test_each_problem_has_its_own_status():
    # w = 0 converges in one Newton step; near the wall within 3 iterations it does not; the straight
    # line from x = 0 to x = 2 meets the wall x = 1 at node 32 of 64, where the barrier is infinite.
    batch = pardel.solve_batch(MODEL, q0=[0, 0], qN=[[0.5, 1], [0.95, 0], [2, 0], [0.25, -1]], T=2, N=64,
                               params={"w": [0, 0.3, 0.2, 0]}, max_iterations=3, error_estimate=False)
    assert list(batch.status) == ["converged", "max_iterations", "non_finite", "converged"]
    assert list(batch.converged) == [True, False, False, True]
    assert "node 32" in batch[2].message
    alone = pardel.solve(MODEL, q0=[0, 0], qN=[0.25, -1], T=2, N=64, params={"w": 0}, max_iterations=3,
                         error_estimate=False, threads=1)
    assert same(batch.q[3], alone.q)


def test_a_single_value_is_broadcast_over_the_batch():
    batch = pardel.solve_batch(MODEL, q0=[0, 0], qN=[0.5, 0.5], T=T, N=N, params={"w": [0.0, 0.1, 0.2]})
    assert len(batch) == 3 and batch.converged.all()
    assert np.all(batch.q[:, 0] == 0) and np.all(batch.q[:, -1] == 0.5)
    single = pardel.solve_batch(MODEL, q0=[0, 0], qN=[0.5, 0.5], T=T, N=N)
    assert len(single) == 1 and same(single.q[0], batch.q[0])
    table = pardel.solve_batch(MODEL, q0=[0, 0], qN=[0.5, 0.5], T=T, N=N, params=[[0, 0, 0.1], [0, 0, 0.2]])
    assert same(table.q, batch.q[1:])


@pytest.mark.parametrize("arguments, error, match", [
    (dict(q0=np.zeros((3, 2)), qN=np.ones((4, 2))), pardel.PardelError, r"batch sizes .* q0 has 3, qN has 4"),
    (dict(q0=[0, 0], qN=[1, 1], params={"w": [0.1, 0.2], "gx": [0, 0, 0]}), pardel.PardelError,
     r"params\['w'\] has 2, params\['gx'\] has 3"),
    (dict(q0=np.zeros((3, 3)), qN=[1, 1]), pardel.PardelError, r"q0 must have 2 values per problem .* shape \(3, 3\)"),
    (dict(q0=[0, 0], qN=[1, 1], guess=np.zeros((2, 5, 3))), pardel.PardelError, r"guess must have 2 values per node"),
    (dict(q0=[0, 0], qN=[1, 1], guess=np.zeros((2, 1, 2))), pardel.PardelError, r"guess must have at least 2 nodes"),
    (dict(q0=[0, 0], qN=[1, 1], params=np.zeros((2, 4))), pardel.PardelError, r"params must have 3 values .* 3 params"),
    (dict(q0=[0, 0], qN=[1, 1], guess=np.zeros((2, 2, 2, 2))), pardel.PardelError, r"guess must be an array"),
    (dict(q0=np.zeros((0, 2)), qN=[1, 1]), pardel.PardelError, r"empty batch"),
    (dict(q0="0 0", qN=[1, 1]), TypeError, r"pardel.solve_batch: q0 must be an array"),
    (dict(q0=[0, 0], qN=[1, np.nan]), pardel.PardelError, r"qN must be finite"),
    (dict(q0=[0, 0], qN=[1, 1], threads=0.5), TypeError, r"threads must be an int"),
    (dict(q0=[0, 0], qN=[1, 1], method="bogus"), pardel.PardelError, r"^pardel\.solve_batch: .*unknown method 'bogus'"),
])
def test_errors_name_the_argument(arguments, error, match):
    with pytest.raises(error, match=match):
        pardel.solve_batch(MODEL, T=T, N=N, **arguments)


def test_missing_arguments():
    with pytest.raises(TypeError, match=r"pardel.solve_batch: missing argument qN"):
        pardel.solve_batch(MODEL, q0=[0, 0], T=T, N=N)
    with pytest.raises(TypeError, match=r"pardel.solve_batch: missing argument N"):
        pardel.solve_batch(MODEL, q0=[0, 0], qN=[1, 1], T=T)


def test_sigint_stops_the_batch_and_other_threads_run_meanwhile():
    import signal
    import threading

    model = pardel.model(MODEL)  # compiled before the timer starts
    ticks = []
    stop = threading.Event()

    def count():  # runs only while the batch has released the GIL
        while not stop.is_set():
            ticks.append(1)
            stop.wait(0.01)

    counter = threading.Thread(target=count)
    timer = threading.Timer(0.5, lambda: signal.pthread_kill(threading.main_thread().ident, signal.SIGINT))
    counter.start()
    timer.start()
    try:
        # 64 problems by jacobi-newton at N = 400, 10^8 sweeps each: hours unless stopped.
        with pytest.raises(KeyboardInterrupt) as info:
            pardel.solve_batch(model, q0=[0, 0], qN=[0.5, 0.5], T=T, N=400, params={"w": np.linspace(0, 0.3, 64)},
                               method="jacobi-newton", max_iterations=100000000, threads=2)
    finally:
        timer.cancel()
        stop.set()
        counter.join()
    assert len(ticks) > 5
    # The batch so far comes with the interruption: the problems that ended (the faint barriers
    # converge in time) with their statuses, the others interrupted with their iterate (a stopped
    # one) or their initial guess (one never started).
    assert isinstance(info.value, pardel.Interrupted)
    so_far = info.value.result
    assert isinstance(so_far, pardel.BatchResult) and len(so_far) == 64
    assert set(so_far.status) <= {"converged", "interrupted"} and "interrupted" in set(so_far.status)
    assert so_far.q.shape == (64, 401, 2) and np.isfinite(so_far.q).all()
    ended = int(np.sum(so_far.status != "interrupted"))
    assert "interrupted with %d of 64 problems ended" % ended in str(info.value)
    after = pardel.solve_batch(model, q0=[0, 0], qN=[0.5, 0.5], T=T, N=20)
    assert after.converged.all()


def test_a_batch_too_large_for_the_machine_is_refused_before_solving():
    # 1000 trajectories of 50 million nodes: 1.2 TB for the results alone.
    with pytest.raises(pardel.PardelError, match=r"a batch of 1000 problems: grid.N = 50000000 needs an estimated"):
        pardel.solve_batch(MODEL, q0=np.zeros((1000, 2)), qN=[0.5, 0.5], T=T, N=50000000)


def test_a_refused_problem_reports_no_residual_action_or_cost():
    # A mass of zero makes the Lagrangian degenerate for that problem alone: invalid_input, with
    # NaN (None in its summary) where nothing was computed, never zeros that read as a solution.
    lag = "model springy\ncoords x\nparam m = 1\nL = 1/2*m*x'^2 - 1/2*x^2\n"
    b = pardel.solve_batch(lag, q0=[0], qN=[1], T=1.0, N=20, params={"m": np.array([1.0, 0.0, 2.0])})
    assert list(b.status) == ["converged", "invalid_input", "converged"]
    assert np.isnan(b.residual[1]) and np.isnan(b.action[1]) and np.isnan(b.cost[1])
    assert np.all(np.isfinite(b.residual[[0, 2]]))
    summary = b[1].summary
    assert summary["residual"] is None and summary["action"] is None and summary["cost"]["value"] is None


def test_a_batch_refuses_what_it_does_not_take():
    with pytest.raises(pardel.PardelError, match=r"give guess or polyline, not both"):
        pardel.solve_batch(MODEL, q0=[0, 0], qN=[0.2, 0.1], T=T, N=N, guess=np.zeros((3, 2)),
                           polyline=[[0, 0], [0.1, 0.5], [0.2, 0.1]])
    with pytest.raises(TypeError, match=r"on_iteration is pardel.solve's; a batch takes none"):
        pardel.solve_batch(MODEL, q0=[0, 0], qN=[0.2, 0.1], T=T, N=N, on_iteration=lambda *a: True)
    with pytest.raises(pardel.PardelError, match=r"give guess or polyline, not both"):
        pardel.solve(MODEL, q0=[0, 0], qN=[0.2, 0.1], T=T, N=N, guess=np.zeros((3, 2)),
                     polyline=[[0, 0], [0.1, 0.5], [0.2, 0.1]])


def test_empty_params_of_a_model_without_params_are_accepted_as_by_solve():
    # params=[] for a model with no params: pardel.solve takes it; the batch indexed the empty
    # array and raised numpy's IndexError.
    batch = pardel.solve_batch("fuel_nav", q0=[0, 0], qN=[[6, 5], [5, 5]], T=30, N=20, params=[])
    alone = pardel.solve("fuel_nav", q0=[0, 0], qN=[5, 5], T=30, N=20, params=[], threads=1)
    assert len(batch) == 2 and same(batch.q[1], alone.q)

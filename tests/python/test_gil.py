"""The GIL is released during a solve and during a .lag compile: another Python thread finishes
its work while a solve runs in a thread, and that solve's answer is the one the main thread gets;
the main thread keeps running while a thread compiles a model."""
import threading
import time

import numpy as np

import pardel


def test_other_threads_run_during_a_solve(spring_lag):
    # jacobi-newton on N = 400 needs far more than 300000 sweeps: the solve runs to max_iterations.
    arguments = dict(q0=[0, 0], qN=[1, 2], T=2.0, N=400, method="jacobi-newton", max_iterations=300000, threads=1)
    out = {}
    started = threading.Event()

    def run():
        started.set()
        out["result"] = pardel.solve(spring_lag, **arguments)

    worker = threading.Thread(target=run)
    worker.start()
    started.wait()
    total = 0
    for i in range(200000):  # pure-Python work, impossible while another thread holds the GIL
        total += i
    still_solving = worker.is_alive()
    worker.join()
    assert total == 200000 * 199999 // 2
    assert still_solving, "the main thread could not run while the solve ran"
    r = out["result"]
    assert r.status == "max_iterations" and r.iterations == 300000
    again = pardel.solve(spring_lag, **dict(arguments, max_iterations=1000))
    assert again.iterations == 1000
    assert np.all(np.isfinite(r.q))


def test_other_threads_run_during_a_model_compile(fresh_chain_lag, tmp_path, monkeypatch):
    # Fresh .lag text in an empty cache: pardel-gen, the render script and the C++ compiler run
    # (about a second) while the main thread keeps counting.
    monkeypatch.setenv("PARDEL_CACHE_DIR", str(tmp_path))
    text = fresh_chain_lag()
    out = {}

    def run():
        out["model"] = pardel.model(text)

    worker = threading.Thread(target=run)
    start = time.perf_counter()
    worker.start()
    counted, longest_gap, last = 0, 0.0, time.perf_counter()
    while worker.is_alive():
        counted += 1  # pure-Python work: it stops while another thread holds the GIL
        now = time.perf_counter()
        longest_gap, last = max(longest_gap, now - last), now
    worker.join()
    compile_seconds = time.perf_counter() - start
    assert out["model"].name == "python_chain" and len(out["model"].coords) == 10
    assert compile_seconds > 0.5, "the compile was too quick to tell (%.3f s)" % compile_seconds
    # Held GIL: one gap as long as the compile. Released: the main thread waits at most a few
    # switch intervals (5 ms) at a time.
    assert longest_gap < 0.25 * compile_seconds, "main thread stopped %.3f s of a %.3f s compile" % (
        longest_gap, compile_seconds)
    assert counted > 1000

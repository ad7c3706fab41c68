"""The GIL is released during a solve: another Python thread finishes its work while a solve runs
in a thread, and that solve's answer is the one the main thread gets."""
import threading

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

"""Ctrl-C stops a long solve: a SIGINT delivered while pardel.solve runs (with the GIL released)
raises KeyboardInterrupt in the caller, and the module keeps working afterwards."""
import signal
import threading

import pytest

import pardel


def test_sigint_raises_keyboard_interrupt(spring_lag):
    seen = {"after": 0}
    spring_lag = pardel.model(spring_lag)  # compiled before the timer starts
    timer = threading.Timer(0.3, lambda: signal.pthread_kill(threading.main_thread().ident, signal.SIGINT))
    timer.start()
    try:
        # jacobi-newton, N = 400, 10^8 sweeps: hours unless stopped.
        with pytest.raises(KeyboardInterrupt):
            pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2.0, N=400, method="jacobi-newton",
                         max_iterations=100000000, threads=1)
    finally:
        timer.cancel()
    # the module is usable after the interruption
    r = pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2.0, N=20)
    seen["after"] = r.iterations
    assert r.status == "converged" and seen["after"] >= 1


def test_interrupt_main_raises_keyboard_interrupt(spring_lag):
    import _thread

    spring_lag = pardel.model(spring_lag)  # compiled before the timer starts
    timer = threading.Timer(0.3, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2.0, N=400, method="jacobi-newton",
                         max_iterations=100000000, threads=1)
    finally:
        timer.cancel()

"""Ctrl-C stops a long solve: a SIGINT delivered while pardel.solve runs (with the GIL released)
raises KeyboardInterrupt in the caller, and the module keeps working afterwards. Ctrl-C during a
.lag compile raises at once, without waiting for the compiler."""
import signal
import threading
import time

import pytest

import pardel


def test_sigint_raises_keyboard_interrupt(spring_lag):
    seen = {"after": 0}
    spring_lag = pardel.model(spring_lag)  # compiled before the timer starts
    timer = threading.Timer(0.3, lambda: signal.pthread_kill(threading.main_thread().ident, signal.SIGINT))
    timer.start()
    try:
        # jacobi-newton, N = 400, 10^8 sweeps: hours unless stopped.
        with pytest.raises(KeyboardInterrupt) as caught:
            pardel.solve(spring_lag, q0=[0, 0], qN=[1, 2], T=2.0, N=400, method="jacobi-newton",
                         max_iterations=100000000, threads=1)
    finally:
        timer.cancel()
    # the stopped solve's message names Ctrl-C, not the on_iteration callback nobody passed
    assert isinstance(caught.value, pardel.Interrupted)
    assert "interrupted by Ctrl-C (KeyboardInterrupt) at iteration" in caught.value.result.message
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


def test_sigint_during_a_model_compile_does_not_wait_for_the_compiler(fresh_chain_lag, tmp_path, monkeypatch):
    # Fresh .lag text in an empty cache: the compile takes about a second. Ctrl-C raises at once;
    # the compile finishes in the background and the next load of the same text finds it complete.
    monkeypatch.setenv("PARDEL_CACHE_DIR", str(tmp_path))
    text = fresh_chain_lag()
    sent = {}

    def interrupt():
        sent["at"] = time.perf_counter()
        signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)

    timer = threading.Timer(0.1, interrupt)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            pardel.model(text)
        raised = time.perf_counter()
    finally:
        timer.cancel()
    model = pardel.model(text)  # waits for the compile that went on
    loaded = time.perf_counter()
    assert model.name == "python_chain" and model.params == {"k": 1.5}
    assert raised - sent["at"] < 0.5, "KeyboardInterrupt came %.3f s after Ctrl-C" % (raised - sent["at"])
    assert loaded - raised > 0.3, "the compile ended %.3f s after Ctrl-C: too quick to tell" % (loaded - raised)
    r = pardel.solve(model, q0=[0] * 10, qN=[0.1] * 10, T=1.0, N=20)
    assert r.status == "converged"

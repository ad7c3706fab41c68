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


_COMPILE_IN_CHILD = """
import sys
import pardel
sys.stdout.write("start\\n"); sys.stdout.flush()
try:
    model = pardel.model(open(sys.argv[1]).read())
    print("compiled")
except KeyboardInterrupt:
    print("KeyboardInterrupt")
"""


def _children(pid):
    """The pids of the processes whose parent is `pid` (from /proc)."""
    import os

    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open("/proc/%s/stat" % entry) as stat:
                    fields = stat.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.append(int(entry))
    return found


def test_ctrl_c_at_a_terminal_does_not_kill_the_compiler(fresh_chain_lag, tmp_path):
    # A terminal's Ctrl-C signals the whole foreground process group: a Python process compiling a
    # fresh .lag, in a session of its own here, gets SIGINT sent to its group once its compiler
    # runs. It raises KeyboardInterrupt (not a failed compile); the compiler, in a group of its
    # own, completes the cache entry, which the next process loads.
    import os
    import subprocess
    import sys

    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    env = dict(os.environ, PARDEL_CACHE_DIR=str(cache))
    lag = tmp_path / "text.lag"
    lag.write_text(fresh_chain_lag())
    command = [sys.executable, "-c", _COMPILE_IN_CHILD, str(lag)]
    child = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             start_new_session=True)
    assert child.stdout.readline() == "start\n"
    deadline = time.monotonic() + 60
    while not _children(child.pid) and child.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    assert _children(child.pid), "the compile did not start a program"
    os.killpg(child.pid, signal.SIGINT)
    out, err = child.communicate(timeout=300)
    assert child.returncode == 0, err
    assert out.strip() == "KeyboardInterrupt", (out, err)
    again = subprocess.run(command, env=env, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and again.stdout.split() == ["start", "compiled"], (again.stdout, again.stderr)

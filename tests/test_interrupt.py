"""Ctrl-C stops a long run promptly with KeyboardInterrupt, and nothing keeps running."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

SCRIPT = textwrap.dedent(
    """
    import sys, crandall
    scene = crandall.Scene.scaled(tau0=50.0, times=[1.0, 50.0])
    print("started", flush=True)
    try:
        crandall.simulate(scene, paths=10**9, seed=1, dt=0.001, threads=2)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(3)
    """
)


def _ctrl_c(script, timeout):
    """Run ``script`` (which prints "started" and then runs far longer than the test), press
    Ctrl-C 1.5 s after it started, and wait up to ``timeout`` s for it to exit.

    Returns (return code, stdout, stderr, seconds from Ctrl-C to the exit)."""
    # A shell without job control starts background commands with SIGINT ignored, and Python
    # then installs no Ctrl-C handler; give the child the default disposition a terminal gives.
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        assert proc.stdout.readline().strip() == "started"
        time.sleep(1.5)  # well inside the run
        assert proc.poll() is None
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=timeout)
        elapsed = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, out, err, elapsed


def _stops_within(script, *, timeout, limit):
    """Ctrl-C (:func:`_ctrl_c`) ends ``script`` with its KeyboardInterrupt handler (exit 3,
    "interrupted") within ``limit`` seconds."""
    returncode, out, err, elapsed = _ctrl_c(script, timeout=timeout)
    assert returncode == 3, err
    assert "interrupted" in out
    assert elapsed < limit, f"took {elapsed:.2f} s to stop"


@pytest.mark.skipif(not hasattr(signal, "SIGINT"), reason="needs POSIX signals")
def test_ctrl_c_stops_a_long_run_within_a_second():
    _stops_within(SCRIPT, timeout=10, limit=1.0)  # the run would take hours


# More threads than cores, and one block of paths: the calling thread may hold no block at all,
# and used to wait for the others at the end of the parallel region without checking for
# Ctrl-C (no exit in 38 s).
SINGLE_BLOCK = textwrap.dedent(
    """
    import sys, crandall
    print("started", flush=True)
    try:
        crandall.simulate(crandall.Scene.scaled(tau0=5.0, times=[5.0]), paths=100, seed=1,
                          dt=1e-9, threads=8)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(3)
    """
)


@pytest.mark.skipif(not hasattr(signal, "SIGINT"), reason="needs POSIX signals")
def test_ctrl_c_with_more_threads_than_cores_and_a_single_block():
    returncode, out, err, elapsed = _ctrl_c(SINGLE_BLOCK, timeout=30)  # the run: about a day
    assert returncode == 3, err
    assert "interrupted" in out
    assert elapsed < 3.0, f"took {elapsed:.2f} s to stop"


ADAPTIVE_SCRIPT = textwrap.dedent(
    """
    import sys, crandall
    scene = crandall.Scene.scaled(tau0=5.0, times=[1.0, 5.0])
    print("started", flush=True)
    try:
        crandall.simulate(scene, error=1e-5, seed=1, threads=2, max_seconds=1e9)  # hours
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(3)
    """
)


@pytest.mark.skipif(not hasattr(signal, "SIGINT"), reason="needs POSIX signals")
def test_ctrl_c_stops_a_run_to_an_accuracy_within_a_second():
    _stops_within(ADAPTIVE_SCRIPT, timeout=10, limit=1.0)


# Paths of 10^9 steps (t0 = 1e6 s): one block of 256 paths takes minutes, and the accuracy
# path polled Ctrl-C only between blocks (77 s to stop with one thread, none within 120 s with
# two). The team of every run polls inside blocks too.
LONG_PATHS_SCRIPT = textwrap.dedent(
    """
    import sys, crandall
    print("started", flush=True)
    try:
        crandall.simulate(crandall.Scene(mu=0.3, h=1.0, t0=1e6, times=[1e6]), error=1e-3, seed=1, max_seconds=1e9,
                          threads={threads})
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(3)
    """
)


@pytest.mark.skipif(not hasattr(signal, "SIGINT"), reason="needs POSIX signals")
@pytest.mark.parametrize("threads", [1, 2])
def test_ctrl_c_stops_a_run_to_an_accuracy_with_long_paths(threads):
    returncode, out, err, elapsed = _ctrl_c(LONG_PATHS_SCRIPT.format(threads=threads), timeout=10)
    assert returncode == 3, err
    assert "interrupted" in out
    assert elapsed < 1.0, f"took {elapsed:.2f} s to stop"


TAIL_SCRIPT = textwrap.dedent(
    """
    import json, sys, crandall
    scene = crandall.Scene.scaled(tau0=5.0, times=[5.0])
    print("started", flush=True)
    try:
        crandall.tail(scene, "distance_at_stop", [60.0], seed=1, rel_error=0.01, threads=2,
                      checkpoint=sys.argv[1] if len(sys.argv) > 1 else None)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(3)
    """
)


@pytest.mark.skipif(not hasattr(signal, "SIGINT"), reason="needs POSIX signals")
def test_ctrl_c_stops_a_tail_run_within_a_second(tmp_path):
    # A splitting run to 1 % (minutes): once its checkpoint holds a finished replica, Ctrl-C
    # ends it between two short core calls, and the checkpoint keeps what finished.
    import json

    path = tmp_path / "tail.json"
    script = TAIL_SCRIPT.replace("sys.argv[1] if len(sys.argv) > 1 else None", repr(str(path)))
    script = script.replace("[60.0]", "[40.0]")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        assert proc.stdout.readline().strip() == "started"
        deadline = time.monotonic() + 120
        while not path.exists() and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        assert path.exists() and proc.poll() is None
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=10)
        elapsed = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 3, err
    assert "interrupted" in out
    assert elapsed < 1.0, f"took {elapsed:.2f} s to stop"
    import numpy as np
    with np.load(path) as stored:
        state = json.loads(str(stored["state"]))
    assert state["samples"], "no finished replica was kept"


# A Newmark sweep long enough to want stopping (4e9 record samples: about 16 s at 4 ns per
# sample): the core gets it in calls of records.SWEEP_SAMPLES, and Ctrl-C between two.
NEWMARK_SWEEP = textwrap.dedent(
    """
    import sys, numpy as np, crandall
    a = 0.3 * np.sin(np.arange(200_000) * 0.05)
    record = crandall.Record(a, 0.01, units="g", name="sine")
    print("started", flush=True)
    try:
        crandall.newmark(record, ky=np.linspace(0.01, 0.29, 20_000), polarity="both",
                         threads=1)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(3)
    """
)


@pytest.mark.skipif(not hasattr(signal, "SIGINT"), reason="needs POSIX signals")
def test_ctrl_c_stops_a_long_newmark_sweep_within_a_second():
    _stops_within(NEWMARK_SWEEP, timeout=60, limit=1.0)

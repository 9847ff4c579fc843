"""No C++ exception or interpreter shutdown ends the process abnormally.

A daemon thread still simulating when the interpreter exited aborted the process ("FATAL:
exception not rethrown", SIGABRT, 3 runs in 4); a std::bad_alloc inside the threads under a
memory limit terminated it.
"""

import subprocess
import sys
import textwrap

import pytest

resource = pytest.importorskip("resource")  # POSIX only

DAEMON = textwrap.dedent(
    """
    import threading, time, crandall
    def work():
        crandall.simulate(crandall.Scene.scaled(tau0=50.0, times=[1.0, 50.0]), paths=10**9,
                          seed=1, dt=0.001, threads=2, progress=False)
    threading.Thread(target=work, daemon=True).start()
    time.sleep(0.5)
    print("exiting", flush=True)
    """
)


@pytest.mark.parametrize("attempt", range(4))
def test_interpreter_exit_with_a_run_in_a_daemon_thread(attempt):
    proc = subprocess.run([sys.executable, "-c", DAEMON], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "exiting"
    assert "FATAL" not in proc.stderr and "terminate" not in proc.stderr


# The core directly (no Python-side memory estimate in the way): 10^6 output times with every
# observable and Richardson's three grids need about 1 GB of accumulators per thread and as much
# for the result; under a 2.5 GB address-space limit the allocation fails inside the threads.
OUT_OF_MEMORY = textwrap.dedent(
    """
    import resource, sys
    resource.setrlimit(resource.RLIMIT_AS, (2_500_000_000, 2_500_000_000))
    import numpy as np
    from crandall import _core
    o = _core.Options()
    o.switch_off = 1.0
    o.times = list(np.linspace(0.0, 1.0, 10**6 + 1)[1:])
    o.displacement = o.distance = o.stop = True
    o.method = "richardson"
    o.dt = 1e-6
    o.paths = 1000
    plan = _core.Plan(o)
    try:
        _core.run_chunk(plan, 0, 2)
    except MemoryError as e:
        print(e)
        sys.exit(0)
    sys.exit(5)
    """
)


def test_out_of_memory_in_the_threads_is_a_memory_error():
    proc = subprocess.run([sys.executable, "-c", OUT_OF_MEMORY], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "out of memory" in proc.stdout and "output times" in proc.stdout

import importlib
import math
import os
import site

import numpy as np
import pytest

import crandall
from crandall import _core


@pytest.fixture(autouse=True, scope="session")
def small_runs_go_parallel():
    """The tests' runs are small: every parallel loop of the core goes parallel anyway (one
    path step of work per thread, where runs give each thread about 10 ms of work), so that
    the tests of bitwise results across thread counts do run on several threads. Subprocesses
    run with the rule as shipped."""
    before = _core.set_thread_work(1.0)
    yield
    _core.set_thread_work(before)


@pytest.fixture
def paper_scene():
    """The paper's setting in scaled units, every observable, output times across the stop."""
    return crandall.Scene.scaled(tau0=1.0, times=[0.25, 0.5, 1.0, 1.5, 3.0])


@pytest.fixture
def physical_scene():
    return crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[0.5, 1.0, 2.0, 3.0])


def same_result(a, b):
    """Bitwise equality of every statistic two results hold."""
    assert a.names == b.names
    for name in a.names:
        ma, mb = a.mean(name), b.mean(name)
        va, vb = a.var(name), b.var(name)
        if isinstance(ma, float):
            assert ma == mb and va == vb, name
        else:
            assert (ma == mb).all() and (va == vb).all(), name
    return True



def run_bits(out):
    """A run's numbers as bytes (a result's statistics, each of a list's, a tail's
    probabilities, standard errors and sample count): equal only if bitwise equal."""
    if isinstance(out, list):
        return [run_bits(o) for o in out]
    if isinstance(out, crandall.TailResult):
        return (out.probability.tobytes(), out.stderr.tobytes(), out.samples)
    return [(name, np.asarray(out.mean(name)).tobytes(), np.asarray(out.var(name)).tobytes(),
             np.asarray(out.stderr(name)).tobytes()) for name in out.names]


INF = math.inf


@pytest.fixture(scope="module")
def worker_client():
    """A Dask client of one worker process, for the recipes' Dask legs (tests/recipe_workers.py
    patches its process as a test patches this one). One per test module: a process cluster
    takes about a second to start, and its scheduler runs in this process, where its
    heartbeats' allocations would be traced by a later module's tracemalloc measurements
    (tests/test_result_distributions.py's histogram memory test saw 250 kB of them) if it
    outlived its module. Ephemeral ports, as in tests/test_distributed.py."""
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                       scheduler_port=0, dashboard_address=":0",
                                       worker_dashboard_address=None)
    client = distributed.Client(cluster)
    try:
        # A worker imports by name what the tests send it (tests/recipe_workers.py's
        # functions, the stubs and task functions of the test modules): this folder is on its
        # path, checked here (a task the worker cannot read would leave its run waiting).
        client.run(site.addsitedir, os.path.dirname(os.path.abspath(__file__)))
        client.run(importlib.import_module, "recipe_workers")
        yield client
    finally:
        client.close()
        cluster.close()

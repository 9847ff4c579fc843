import math

import pytest

import crandall


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


INF = math.inf

"""Random streams: every Dask task refuses a client that draws another random stream than its
worker, with one check (crandall.streams.check_random_stream), before it draws anything."""

from __future__ import annotations

import importlib

import pytest

from crandall import _core, adaptive, engine, streams
from crandall.errors import ParameterError
from crandall.scene import Scene
from crandall.spec import RunSpec

tail_module = importlib.import_module("crandall.tail")  # crandall.tail is the function

_SCENE = Scene(mu=0.5, h=1.0, t0=1.0, times=[0.5, 1.0])
_OTHER = streams.RANDOM_STREAM + 1


def _accuracy_config(stream):
    return {"scene": _SCENE.to_dict(), "eps": 0.1, "rel": None, "seed": 1, "threads": 1,
            "statistics": ["velocity:mean"], "centre": [0.0], "beta": None,
            "use_controls": False, "random_stream": stream}


_TAIL_JOB = {"scene": _SCENE.to_dict(), "quantity": "distance_at_stop", "time": None,
             "dt": 0.01, "levels": [0.5], "particles": 10, "key": 1, "proposal": None}

#: Every Dask task of crandall, called as a worker calls it, with the client's stream.
TASKS = {
    "fixed-step chunks": lambda stream: engine.run_chunks(
        RunSpec(_SCENE, 100, 1, 0.01, "exact").to_dict(), 0, 1, 1, stream),
    "accuracy batch": lambda stream: adaptive.batch_task(_accuracy_config(stream), 0, 0, 10),
    "tail sample": lambda stream: tail_module.sample(_TAIL_JOB, 0, 1, None, stream),
}


@pytest.mark.parametrize("task", sorted(TASKS))
def test_every_dask_task_refuses_another_random_stream(task):
    with pytest.raises(ParameterError, match=f"random_stream: this worker's crandall draws "
                                             f"random stream {streams.RANDOM_STREAM}, the "
                                             f"client's draws stream {_OTHER}") as exc:
        TASKS[task](_OTHER)
    assert exc.value.name == "random_stream"


@pytest.mark.parametrize("task", ["fixed-step chunks", "tail sample"])
def test_every_dask_task_runs_with_its_own_random_stream(task):
    # The refusal above comes from the stream alone.
    assert TASKS[task](streams.RANDOM_STREAM)


def test_the_tail_run_gives_its_tasks_the_random_stream():
    run = tail_module._TailRun(_TAIL_JOB, {}, threads=1, task_threads=1, per_sample=1,
                               path_bytes=8, min_samples=3, max_samples=10, rel_error=0.1,
                               max_seconds=10.0, started=0.0)
    for task in run._tasks(0, 2):
        assert task.args[-1] == streams.RANDOM_STREAM


def test_the_core_and_the_streams_agree_on_the_random_stream():
    assert streams.RANDOM_STREAM == engine.RANDOM_STREAM == int(_core.RANDOM_STREAM)

"""The driver (crandall.driver) and the recipe "... an estimator" of docs/architecture.md.

The toy estimator below follows the recipe as written: a module of its own with an
``Estimator`` subclass, its name in ``checkpoint.ESTIMATORS`` and a random stream of its own
from ``crandall.streams``. It estimates E V(tau) of the paper's scene (0 by symmetry) in two
stages, as the real estimators do: a pilot of two batches, then as many batches as the
pilot's variance says a target standard error needs. The tests check that the driver gives it,
with no code of its own, what it gives the fixed-step, accuracy and tail runs: the same bits
locally, after an interruption and resume, and on a Dask cluster; checkpoints refused for
another run or estimator naming the field; the progress text.
"""

import json
import math

import numpy as np
import pytest

import crandall
from crandall import _core, checkpoint, driver, streams

TAU = 1.0
BATCH = 4000
#: The toy's stream (a number no other estimator uses: see crandall.streams).
TOY_STREAM = (1 << 20) + 100


def toy_batch(key: int, index: int, n: int) -> list:
    """One batch: the sum and sum of squares of n exact samples of the scaled V(TAU) from
    rest (a pure function of its arguments: a Dask worker runs it)."""
    v = _core.exact_steps(np.zeros(n), TAU, 2.0, math.sqrt(2.0), streams.key(key, index))
    return [float(v.sum()), float((v * v).sum()), n]


class Toy(driver.Estimator):
    name = "toy"

    def __init__(self, seed: int, stderr: float):
        self.seed, self.target = seed, stderr
        self.key = streams.key(seed, TOY_STREAM)
        self.sums = []  # per batch: [sum, sum of squares, n]
        self.planned = None

    def identity(self):
        return {"seed": self.seed, "stderr": self.target}

    def state(self):
        return {"sums": np.array(self.sums, dtype=float).reshape(-1, 3)}

    def restore(self, arrays, path):
        self.sums = [list(map(float, row)) for row in arrays["sums"]]
        self.sums = [[a, b, int(n)] for a, b, n in self.sums]

    def _tasks(self, first, last):
        return [driver.Task(toy_batch, (self.key, i, BATCH), size=BATCH)
                for i in range(first, last)]

    def rounds(self):
        if len(self.sums) < 2:
            yield self._tasks(len(self.sums), 2)  # the pilot
        s, s2, n = (sum(col) for col in zip(*self.sums[:2]))
        var = s2 / n - (s / n) ** 2
        self.planned = 2 + max(1, math.ceil(var / self.target ** 2 / BATCH))
        while len(self.sums) < self.planned:
            yield self._tasks(len(self.sums), min(self.planned, len(self.sums) + 3))

    def merge(self, task, output):
        self.sums.append(output)

    def progress(self):
        return driver.Progress(len(self.sums), self.planned,
                               "" if self.planned else "pilot")

    def result(self):
        s, s2, n = (sum(col) for col in zip(*self.sums[2:]))
        mean = s / n
        return mean, math.sqrt((s2 / n - mean * mean) / n), n


@pytest.fixture
def toy(monkeypatch):
    monkeypatch.setitem(checkpoint.ESTIMATORS, "toy", "the toy estimator of the tests")


def test_a_new_estimator_runs_with_no_driver_change(toy):
    mean, se, n = driver.drive(Toy(7, 0.01), progress=False)[0]
    # The pilot's 8000 paths estimate Var V to about 2 % (sqrt(2 / 8000)); the plan rounds
    # the batches up: the standard error is at most the target give or take that.
    assert n % BATCH == 0 and n >= 2 * BATCH
    assert se < 0.01 * 1.1
    assert abs(mean) < 4 * se  # E V = 0 by symmetry; 4 standard errors: fails 1 in 16000
    again = driver.drive(Toy(7, 0.01), progress=False)[0]
    assert again == (mean, se, n)


def test_an_interrupted_estimator_resumes_bitwise_and_redoes_nothing(toy, tmp_path,
                                                                     monkeypatch):
    whole = driver.drive(Toy(3, 0.005), progress=False)[0]
    path = tmp_path / "toy.ckpt"
    calls = []

    def interrupting(key, index, n):
        if index == 4:
            raise KeyboardInterrupt
        calls.append(index)
        return toy_batch(key, index, n)

    monkeypatch.setattr(Toy, "_tasks", lambda self, a, b: [
        driver.Task(interrupting, (self.key, i, BATCH)) for i in range(a, b)])
    with pytest.raises(KeyboardInterrupt):
        driver.drive(Toy(3, 0.005), checkpoints=path, progress=False)
    assert calls == [0, 1, 2, 3]  # the pilot and the first of the planned batches
    with np.load(path) as data:
        assert data["sums"].shape == (4, 3)  # what finished was kept
    calls.clear()
    monkeypatch.undo()
    monkeypatch.setitem(checkpoint.ESTIMATORS, "toy", "the toy estimator of the tests")
    counted = []
    real = Toy._tasks
    monkeypatch.setattr(Toy, "_tasks", lambda self, a, b: counted.extend(range(a, b))
                        or real(self, a, b))
    resumed = driver.drive(Toy(3, 0.005), checkpoints=path, progress=False)[0]
    assert resumed == whole
    assert counted and min(counted) == 4  # nothing finished was run again
    # Another run's checkpoint is refused naming the field; another estimator's naming it.
    with pytest.raises(ValueError, match=r"belongs to a different run \(seed: checkpoint has "
                                         r"3, this run 4\)"):
        driver.drive(Toy(4, 0.005), checkpoints=path, progress=False)
    fixed = tmp_path / "fixed.ckpt"
    crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[1.0]), paths=100, seed=3,
                      checkpoint=fixed)
    with pytest.raises(ValueError, match="is a checkpoint of a fixed-step run .* not of the "
                                         "toy estimator of the tests \\(field estimator\\)"):
        driver.drive(Toy(3, 0.005), checkpoints=fixed, progress=False)


def test_the_progress_bar_shows_the_estimators_progress(toy, capsys):
    driver.drive(Toy(5, 0.05), progress=True)
    err = capsys.readouterr().err
    assert "crandall" in err


def test_a_new_estimator_on_a_cluster_is_bitwise_local(toy, worker_client):
    # Its tasks run in a worker's process (which imports toy_batch from this module).
    local = driver.drive(Toy(9, 0.02), progress=False)[0]
    remote = driver.drive(Toy(9, 0.02), client=worker_client, progress=False)[0]
    assert remote == local


def test_the_public_entry_points_are_estimators_under_the_driver(monkeypatch):
    # The recipe's other legs are not a new estimator's: simulate, simulate(error=),
    # simulate_many and crandall.tail are the public functions of the estimators there are,
    # each of which builds its estimator(s), named in checkpoint.ESTIMATORS, and hands them to
    # driver.drive, as a new one's public function does: what the driver gives the toy above,
    # it gives them.
    import importlib
    seen = []

    def spying(real):
        def spy(estimators, **kw):
            listed = estimators if isinstance(estimators, list) else [estimators]
            seen.append([type(e).__name__ for e in listed])
            assert all(isinstance(e, driver.Estimator) and e.name in checkpoint.ESTIMATORS
                       for e in listed)
            return real(estimators, **kw)
        return spy

    for name in ("crandall.simulate", "crandall.adaptive.entry", "crandall.tail.entry"):
        module = importlib.import_module(name)
        monkeypatch.setattr(module, "drive", spying(module.drive))
    sc = crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity", "stop"])
    crandall.simulate(sc, paths=100, seed=1, threads=1)
    crandall.simulate(sc, error=0.2, seed=1, threads=1)
    crandall.simulate_many([sc, sc], paths=100, seed=1, threads=1)
    crandall.tail(sc, "stop_time", [2.0], seed=1, threads=1, rel_error=0.5, min_samples=4,
                  max_samples=4, particles=50)
    assert seen == [["FixedStep"], ["_Engine"], ["FixedStep", "FixedStep"], ["_TailRun"]]


def test_a_client_without_what_the_driver_calls_is_refused(toy):
    with pytest.raises(ValueError, match="client must be a distributed.Client"):
        driver.drive(Toy(1, 0.1), client=object())


def test_several_estimators_keep_their_own_checkpoints(toy, tmp_path):
    paths = [tmp_path / "a.ckpt", tmp_path / "b.ckpt"]
    out = driver.drive([Toy(1, 0.05), Toy(2, 0.05)], checkpoints=paths, progress=False)
    assert out == [driver.drive(Toy(s, 0.05), progress=False)[0] for s in (1, 2)]
    for p, seed in zip(paths, (1, 2)):
        with np.load(p) as data:
            assert json.loads(str(data["identity"]))["seed"] == seed


def test_the_bias_estimate_runs_under_the_driver_with_the_same_bits_in_any_batches(monkeypatch):
    from crandall import bias

    sc = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0], observe=["distance", "stop"])
    r = crandall.simulate(sc, paths=20000, seed=2, method="exact")
    whole = {k: v[0].tobytes() for k, v in bias.estimate(r).items()}
    seen = []
    real = driver.drive

    def spy(est, **kw):
        seen.append(type(est).__name__)
        return real(est, **kw)

    monkeypatch.setattr(bias, "drive", spy)
    monkeypatch.setattr(bias, "BATCH_PATHS", 3000)  # 7 batches, the last one short
    split = {k: v[0].tobytes() for k, v in bias.estimate(r).items()}
    assert seen == ["_CoupledRun"] and split == whole


def test_threads_default_to_every_core_here_and_one_per_cluster_task():
    import os

    assert driver.threads(None) == (os.cpu_count() or 1, 1)
    assert driver.threads(3) == (3, 3)
    for bad in (0, 2.0, "2", True):
        with pytest.raises(ValueError, match="threads"):
            driver.threads(bad)


# OpenMP's wait policy (crandall._openmp): an idle thread of GNU's runtime spun for
# milliseconds between two parallel loops, taking the cores other work on the machine needed
# (issue 30). The runtime reports what it read with OMP_DISPLAY_ENV=verbose.
_POLICY = "import os, crandall; print(os.environ.get('OMP_WAIT_POLICY'))"


def _policy(**user):
    import os
    import re
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items()
           if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "KMP_BLOCKTIME")}
    env.update(user, OMP_DISPLAY_ENV="verbose")
    done = subprocess.run([sys.executable, "-c", _POLICY], env=env, capture_output=True,
                          text=True, check=True)
    spin = re.search(r"GOMP_SPINCOUNT = '(\d+)'", done.stderr)
    if spin is None:
        pytest.skip("the core's OpenMP runtime is not GNU's (no GOMP_SPINCOUNT)")
    return int(spin.group(1)), done.stdout.strip()


def test_openmp_threads_sleep_when_idle_unless_the_user_chose_a_policy():
    # No policy given: passive (no spinning), and the variable is not left to child processes.
    assert _policy() == (0, "None")
    # The user's choice is kept: an active policy spins, GNU's spin count is taken as given.
    spin, left = _policy(OMP_WAIT_POLICY="active")
    assert spin > 0 and left == "active"
    assert _policy(GOMP_SPINCOUNT="1234") == (1234, "None")

"""The tail run as an estimator of the driver (``_TailRun``): its samples, each a pure function
of the job and its index (``sample``, the Dask task), the two-stage sample count, the
checkpoint's samples and their checks, and the memory check."""

from __future__ import annotations

import functools
import hashlib
import json
import math
import time as _time
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from .. import streams as _streams
from .._resources import available_memory
from ..checkpoint import json_state, read_json_state
from ..driver import Estimator, Progress, Task
from ..errors import ParameterError
from ..scene import Scene
from .importance import _importance_batch, _proposal, _TOP_WEIGHTS
from .problem import _grid_for, _Problem
from .result import _stats, StatisticsFailure
from .splitting import _REPLICA_STREAMS, _splitting_replica, _splitting_replicas
#: How many more samples than the pilot's variance asks for the run takes.
SAFETY = 1.3
#: ... or, if larger, as many as the 99 % upper confidence bound of the pilot's variance asks:
#: its variance times (n - 1) / chi2_0.01(n - 1) (2.49 for a pilot of 20 replicas). Splitting
#: replicas are skewed (the distance at 1e-9, normalised score: relative spread 0.58, skewness
#: 1.6), so their sample variance is low more often than a normal sample's: with the 90 % bound,
#: 17 % of runs end above the target relative error there, with the 99 % one 3.9 %
#: (bench/tails_pilot.py). The normal quantile of the bound; chi2 by Wilson & Hilferty's cube
#: (plain float arithmetic, the same on every machine).
UPPER_Z = 2.3263478740408408
#: Splitting replicas of a white-noise scene a thread runs in step (_LocalReplicas): an
#: iteration continues a tenth of a replica's particles (20 of the default 200), which leave
#: about 40 % of the 16 vector lanes idle at the paper's stop time; four replicas fill them.
GROUP = 4


def variance_upper_factor(n: int) -> float:
    """(n - 1) / chi2_0.01(n - 1): the 99 % upper confidence bound of a variance estimated from
    n samples, over the estimate (normal samples; Wilson-Hilferty's approximation of the
    chi-square quantile: above it for few degrees of freedom (1.5 times at 3, 1.02 at 9),
    within 0.5 % from 19 on; infinite below 3)."""
    k = n - 1
    if k < 1:
        return math.inf
    c = 2.0 / (9.0 * k)
    cube = 1.0 - c - UPPER_Z * math.sqrt(c)
    return math.inf if cube <= 0 else 1.0 / cube ** 3


def sample(job: Dict[str, Any], index: int, threads: int = 0,
           deadline: Optional[float] = None,
           random_stream: Optional[int] = None) -> Dict[str, Any]:
    """Sample ``index`` of a tail run described by ``job`` (plain data: the scene's dict, the
    quantity, time, grid step, levels, particles, key and, for importance sampling, the
    proposal): a splitting replica, or a batch of ``particles`` weighted paths. A pure function
    of (job, index): the Dask task of a tail run. A replica still running at ``deadline`` (a
    ``time.time()``, the run's max_seconds) stops between its iterations and returns only
    ``timed_out`` and how far it got (no sample: the run leaves it out). ``random_stream``:
    the client's, given to a Dask task (:func:`crandall.streams.check_random_stream`)."""
    if random_stream is not None:
        _streams.check_random_stream(random_stream)
    problem = _problem(job)
    lv = np.asarray(job["levels"], dtype=float)
    n, key = job["particles"], job["key"]
    if job["proposal"] is None:
        # A guard against a run that does not progress.
        return _replica_output(*_splitting_replica(problem, lv, n, max(1, n // 10), key, index,
                                                   threads, _max_iterations(n),
                                                   deadline=deadline))
    window, drift, slow, full = job["proposal"]
    grid = _grid_for(problem, window)
    contrib = _importance_batch(grid, _proposal(grid, window, drift, slow, full), lv, n, key,
                                index * _REPLICA_STREAMS, threads)
    return {"paths": n, "steps": n * grid.steps,
            "sum": contrib.sum(axis=0).tolist(),
            "sum2": (contrib ** 2).sum(axis=0).tolist(),
            "hits": np.count_nonzero(contrib, axis=0).tolist(),
            "top": [np.sort(col[col > 0])[-_TOP_WEIGHTS:].tolist() for col in contrib.T]}


def samples(job: Dict[str, Any], indices: Sequence[int], threads: int = 1,
            deadline: Optional[float] = None) -> List[Dict[str, Any]]:
    """``sample(job, i)`` for each i of ``indices``, bit for bit; a white-noise scene's
    splitting replicas run in the core in step (their clones share the vector lanes)."""
    if job["proposal"] is not None:
        return [sample(job, i, threads, deadline) for i in indices]
    problem = _problem(job)
    n = job["particles"]
    return [_replica_output(est, info) for est, info in _splitting_replicas(
        problem, np.asarray(job["levels"], dtype=float), n, max(1, n // 10), job["key"],
        list(indices), threads, _max_iterations(n), deadline=deadline)]


def _problem(job: Dict[str, Any]) -> _Problem:
    return _Problem(Scene.from_dict(job["scene"]), job["quantity"], job["time"], job["dt"])


def _replica_output(est: np.ndarray, info: Dict[str, Any]) -> Dict[str, Any]:
    """A splitting replica's sample: its estimates and counts, or, stopped by the deadline,
    only ``timed_out`` and how far it got."""
    if info.get("timed_out"):
        return {"timed_out": True, "iterations": info["iterations"],
                "log_weight": info["log_weight"]}
    return {"estimates": est.tolist(), "iterations": info["iterations"],
            "steps": info["steps"], "extinct": info["extinct"]}


def _canonical(data) -> bytes:
    """Plain data as canonical JSON (keys sorted; floats as Python writes them, which read
    back exactly), one line: what the checkpoint's checksum is computed over."""
    return json.dumps(data, sort_keys=True, separators=(",", ":")).encode("utf-8") + b"\n"


def _digest(spec: Dict[str, Any], samples: Sequence[Dict[str, Any]]):
    """The SHA-256 of a tail run's spec followed by its samples (hashlib's object: a run
    updates it with each sample it merges, so that a checkpoint costs no second pass)."""
    digest = hashlib.sha256(_canonical(spec))
    for s in samples:
        digest.update(_canonical(s))
    return digest


def _max_iterations(particles: int) -> int:
    """The iterations after which a splitting replica gives up: 200 n log(1/p) / n for
    log(1/p) up to about 12000, never reached by a run that progresses."""
    return 200 * particles * 60


def _check_samples(samples: Sequence[Dict[str, Any]], job: Dict[str, Any], most: int) -> None:
    """Check a checkpoint's samples against what the run ``job`` can have written: at most
    ``most`` of them, each with its fields, of the right types, lengths and ranges, and
    consistent with each other. A ValueError whose text starts with the field
    ("samples[3].estimates: ...")."""
    if len(samples) > most:
        raise ValueError(f"samples: {len(samples)} of them, more than the {most} this run can "
                         "take")
    levels, n = len(job["levels"]), job["particles"]
    problem = _Problem(Scene.from_dict(job["scene"]), job["quantity"], job["time"], job["dt"])
    splitting = job["proposal"] is None
    steps = problem.steps if splitting else _grid_for(problem, job["proposal"][0]).steps

    def integer(i, key, lo, hi=None):
        v = samples[i].get(key)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
            raise ValueError(f"samples[{i}].{key}: {v!r} is not a whole number in "
                             f"[{lo}, {'...' if hi is None else hi}]")
        return v

    def per_level(i, key, lo, hi=math.inf):
        v = samples[i].get(key)
        if (not isinstance(v, list) or len(v) != levels
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)):
            raise ValueError(f"samples[{i}].{key}: not a list of numbers, one per level "
                             f"({levels})")
        a = np.array(v, dtype=float)
        if not (np.all(np.isfinite(a)) and np.all(a >= lo) and np.all(a <= hi)):
            raise ValueError(f"samples[{i}].{key}: {v} holds a number that is not finite or "
                             f"not in [{lo:g}, {hi:g}]")
        return a

    for i in range(len(samples)):
        if splitting:
            est = per_level(i, "estimates", 0.0, 1.0)
            iterations = integer(i, "iterations", 0, _max_iterations(n))
            # A replica's steps: its n paths whole, then at most n - 1 continued per iteration.
            integer(i, "steps", n * steps, n * steps + iterations * (n - 1) * steps)
            # The last level's estimate is taken at the last iteration (or is 0): at most the
            # weight, each iteration having killed at least kill = n // 10 of the particles. The
            # weight is a product of the iterations' (n - K_j) / n in order (splitting.py), and
            # rounding is monotone, so it is at most the same product of (n - kill) / n: an
            # exact comparison with +, -, *, / only, the same on every CPU. (The factor
            # 1 + 1e-9 admits samples whose weight was an exp of a sum of logarithms, within a
            # few ulps of the product: older checkpoints.)
            kill = max(1, n // 10)
            bound = 1.0
            for _ in range(iterations):
                bound = bound * ((n - kill) / n)
                if bound == 0.0:
                    break  # (a few thousand iterations at most: the factor is below 0.95)
            if est[-1] > bound * (1.0 + 1e-9):
                raise ValueError(f"samples[{i}].estimates: {float(est[-1])!r} at the last "
                                 f"level, above the weight {iterations} iterations leave")
            continue
        integer(i, "paths", n, n)
        integer(i, "steps", n * steps, n * steps)
        s1, s2 = per_level(i, "sum", 0.0), per_level(i, "sum2", 0.0)
        hits = samples[i].get("hits")
        if (not isinstance(hits, list) or len(hits) != levels
                or not all(isinstance(h, int) and not isinstance(h, bool) and 0 <= h <= n
                           for h in hits)):
            raise ValueError(f"samples[{i}].hits: not a list of whole numbers in [0, {n}], one "
                             f"per level ({levels})")
        top = samples[i].get("top")
        if not isinstance(top, list) or len(top) != levels:
            raise ValueError(f"samples[{i}].top: not a list of lists, one per level ({levels})")
        for j in range(levels):
            t = top[j]
            if (not isinstance(t, list) or len(t) != min(hits[j], _TOP_WEIGHTS)
                    or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in t)):
                raise ValueError(f"samples[{i}].top[{j}]: not the {min(hits[j], _TOP_WEIGHTS)} "
                                 "largest weights past the level")
            t = np.array(t, dtype=float)
            if not (np.all(np.isfinite(t)) and np.all(t > 0) and np.all(np.diff(t) >= 0)):
                raise ValueError(f"samples[{i}].top[{j}]: not positive finite weights in "
                                 "ascending order")
            # Sums of `hits` weights, each at most the largest, which they hold: exact bounds
            # but for the rounding of a sum of at most n terms (below n 2^-53, well within
            # 1e-6). The squares' bounds are taken in units of the largest weight, and only
            # where its square is a normal double (a subnormal one has lost its digits).
            m = t[-1]
            if hits[j] and not (m <= s1[j] <= hits[j] * m * (1 + 1e-6) and m * m <= s2[j] and (
                    m < 1e-100 or (s2[j] / m <= s1[j] * (1 + 1e-6)
                                   and (s1[j] / m) ** 2 <= hits[j] * (s2[j] / m / m) * (1 + 1e-6)))):
                raise ValueError(f"samples[{i}].sum: {float(s1[j])!r} (sum2 {float(s2[j])!r}) at "
                                 f"level {j} cannot be the sum of {hits[j]} weights up to "
                                 f"{float(t[-1])!r}")
            if not hits[j] and (s1[j] or s2[j]):
                raise ValueError(f"samples[{i}].sum: {float(s1[j])!r} at level {j}, where no path "
                                 "hit")
        # The paths past a level are among those past any lower one.
        if np.any(np.diff(hits) > 0) or np.any(np.diff(s1) > 0) or np.any(np.diff(s2) > 0):
            raise ValueError(f"samples[{i}].hits: the hits or sums grow with the level")


class _TailRun(Estimator):
    """A tail run's samples (splitting replicas or batches of weighted paths) as the driver's
    estimator: each sample a pure function of the job and its index, run here or as a Dask
    task; the checkpoint holds the finished samples.

    Two stages, so that when to stop never depends on the estimate itself (stopping when the
    running error first looks small enough would favour runs whose rare large contributions
    have not come yet, a bias towards small probabilities): a pilot of ``min_samples`` samples,
    left out of the estimate, gives the variance per sample, hence the number of samples the
    target needs; then exactly that many (or fewer when max_samples or max_seconds ends the
    run: a cut that does not depend on their values either).
    """

    name = "tail"

    def __init__(self, job, spec, *, threads, task_threads, per_sample, path_bytes,
                 min_samples, max_samples, rel_error, max_seconds, started, rate=None,
                 steps=0, advice="give a larger max_seconds"):
        self.job, self.spec, self.threads = job, spec, threads
        self.task_threads = task_threads
        self.splitting = job["proposal"] is None
        #: Splitting replicas run at once here (_LocalReplicas): replicas are independent, and
        #: one replica's iterations are too short to share among threads, so each thread runs
        #: its own; a white-noise scene's GROUP of them in step in the core, whose vector
        #: lanes a tenth of one replica's particles would leave idle.
        self.parallel = max(1, threads) if self.splitting else 1
        white = self.splitting and _problem(job).in_core
        self.local_width = self.parallel * (GROUP if white else 1)
        self.levels = len(job["levels"])
        self.max_samples, self.rel_error = max_samples, rel_error
        self.max_seconds, self.started = max_seconds, started
        self.per_sample = per_sample
        self.path_bytes = path_bytes
        self.pilot_n = -(-min_samples // per_sample)
        #: What the pilot's variance is estimated from: replicas, or weighted paths.
        self.pilot_samples = self.pilot_n * per_sample
        self.min_samples = min_samples
        self.samples: List[Dict[str, Any]] = []
        #: The checksum of the spec and the samples merged so far (the checkpoint's).
        self.digest = _digest(spec, [])
        self.target_n: Optional[int] = None
        self.wanted = 0
        self.stopped_early = False
        #: The run's max_seconds as a time.time() (Dask workers compare their clocks with
        #: it): a replica still running then stops between its iterations.
        self.deadline = _time.time() + max_seconds - (_time.perf_counter() - started)
        #: Path-steps per second measured before the run (_rate) and the steps of a
        #: sample's grid: a sample's least cost, its first paths' steps, is estimated from
        #: them before any sample has run.
        self.rate, self.steps = rate, steps
        #: What would help when max_seconds does not suffice (tail()'s words for the case).
        self.advice = advice
        #: The output of a sample stopped by the deadline (no sample: left out).
        self.cut: Optional[Dict[str, Any]] = None
        #: Wall seconds and samples of the batches run in this call (the measured rate).
        self.ran = [0.0, 0]

    def identity(self):
        return self.spec

    def check_memory(self):
        _check_memory(self.job["particles"], self.path_bytes, self.threads, "particles",
                      f"particles: {self.job['particles']} paths", "give fewer particles or a "
                      "larger dt")
        if self.local_width > 1:  # as many replicas at once as fit (one always does)
            room = available_memory() - self.threads * (16 << 20)
            self.local_width = int(max(1, min(self.local_width, room // (
                4 * self.job["particles"] * self.path_bytes))))
            self.parallel = min(self.parallel, self.local_width)

    def state(self):
        return json_state({"samples": self.samples, "checksum": self.digest.hexdigest()})

    def restore(self, arrays, path):
        """Carry on from a checkpoint's samples (its identity already matched this run's).

        Every sample is checked against what this run can have written (types, lengths,
        ranges, and the fields' consistency with each other), naming the field; then the
        checksum, which the run wrote over its spec and the samples, refuses any edit the
        ranges let through (an estimate scaled within [0, 1], another run's samples)."""
        where = f"checkpoint: {path}"
        st = read_json_state(path, arrays, "a tail run")
        samples = st.get("samples")
        if not isinstance(samples, list) or not all(isinstance(x, dict) for x in samples):
            raise ValueError(f"{where} is not a checkpoint of a tail run (field state: samples "
                             "is not a list of tables)")
        try:
            _check_samples(samples, self.job, self.pilot_n + max(2, -(-self.max_samples
                                                                     // self.per_sample)))
        except ValueError as exc:
            raise ValueError(f"{where} is damaged (field {exc}); remove it to start "
                             "again") from None
        digest = _digest(self.spec, samples)
        if st.get("checksum") != digest.hexdigest():
            why = ("missing" if "checksum" not in st else
                   "it does not match the samples and this run's spec: they were edited or "
                   "damaged")
            raise ValueError(f"{where} is damaged (field checksum: {why}); remove it to start "
                             "again")
        self.samples, self.digest = samples, digest

    def _tasks(self, first: int, last: int):
        here = (_LocalReplicas(self.job, first, last, self.deadline, self.parallel, self.threads)
                if self.workers is None and self.local_width > 1 and last - first > 1 else None)
        return [Task(sample, (self.job, i, self.task_threads, self.deadline,
                             _streams.RANDOM_STREAM),
                     here.local(i) if here is not None else
                     functools.partial(sample, self.job, i, self.threads, self.deadline), 1)
                for i in range(first, last)]

    def _elapsed(self) -> float:
        return _time.perf_counter() - self.started

    def _expect(self, count: int) -> float:
        """The seconds ``count`` more samples are expected to take: at the wall time per
        sample of those run in this call; before any, at least their first paths' steps at the
        measured rate (a lower bound: a replica's iterations come on top)."""
        seconds, done = self.ran
        if done:
            return seconds / done * count
        if not self.rate:
            return 0.0
        parallel = max(1, min(count, self.parallel if self.workers is None else self.workers))
        paths = self.job["particles"] * -(-count // parallel)
        return paths * self.steps / self.rate

    def _timed(self, batch):
        """Yield a batch to the driver, timing it (the driver merges it before resuming)."""
        started = _time.perf_counter()
        yield batch
        self.ran[0] += _time.perf_counter() - started
        self.ran[1] += len(batch)

    def _out_of_time(self, what: str) -> ParameterError:
        # Pilot replicas that ended in an extinction (their particles tied below the level)
        # had no particle past it: a sign that the level is out of reach.
        dead = sum(1 for c in self.samples if c.get("extinct") is not None
                   and not np.any(np.asarray(c.get("estimates", [])) > 0))
        out = (f" ({dead} of the {len(self.samples)} replicas run ended with their particles "
               "tied below the levels: they may be beyond what the paths reach)" if dead else "")
        return ParameterError(
            "max_seconds", f"max_seconds: {what}, more than max_seconds={self.max_seconds:g} "
            f"allows ({self._elapsed():.3g} s spent){out}; {self.advice}")

    def _pilot_cut(self) -> ParameterError:
        """The error of a pilot replica stopped by the deadline: how far it got."""
        top = max(self.job["levels"])
        return ParameterError(
            "max_seconds", f"max_seconds: the pilot's replica {len(self.samples)} had not "
            f"reached level {top:g} when max_seconds={self.max_seconds:g} ran out "
            f"({self._elapsed():.3g} s spent, {self.cut['iterations']} iterations; its "
            f"particles had got as far as a probability of about "
            f"{math.exp(self.cut['log_weight']):.1e}): the level is beyond what the paths "
            f"reach in that time; {self.advice}")

    def rounds(self):
        # On a cluster a batch of as many samples as it has threads (at least 8); here one, or
        # for splitting as many replicas as run at once (local_width).
        # A batch is not started when the time per sample measured so far (before any: its
        # least cost at the measured rate) says it would end past max_seconds; a replica
        # running then stops (sample's deadline). A pilot that cannot finish is refused.
        width = self.local_width if self.workers is None else max(8, self.workers)
        what = "replicas" if self.splitting else "batches"
        while len(self.samples) < self.pilot_n:
            last = (self.pilot_n if self.workers is not None
                    else min(self.pilot_n, len(self.samples) + self.local_width))
            left = self.pilot_n - len(self.samples)
            expect = self._expect(left)
            if self._elapsed() + expect > self.max_seconds:
                raise self._out_of_time(
                    f"the pilot's {left} {'remaining ' if self.samples else ''}{what} would "
                    f"take {'about' if self.ran[1] else 'at least'} {expect:.3g} s more")
            yield from self._timed(self._tasks(len(self.samples), last))
            if self.cut is not None:
                raise self._pilot_cut()
        _, pmean, _, pvar = _stats(self.samples[:self.pilot_n], self.splitting, self.levels)
        with np.errstate(divide="ignore", invalid="ignore"):
            need = np.where(pmean > 0, pvar / (self.rel_error * pmean) ** 2, np.nan)
        if np.all(np.isnan(need)):
            low = self.job["levels"][0]
            if not self.splitting:
                raise StatisticsFailure(f"importance: no pilot sample reached level {low:g}; "
                                        "use method='splitting'")
            # Replicas that ended in an extinction: their particles' scores tied below the
            # level, which more particles do not untie.
            reached = [c.get("extinct") for c in self.samples[:self.pilot_n]]
            reached = [x for x in reached if x is not None]
            how = (f"in {'every one' if len(reached) == self.pilot_n else len(reached)} the "
                   f"particles' scores stopped rising below it, all tied (they got as far as "
                   f"a probability of about {math.exp(min(reached)):.1e}): " if reached else "")
            raise StatisticsFailure(
                f"splitting: no pilot replica reached level {low:g}: {how}the level is "
                "beyond what the paths reach; give a smaller level, or try "
                "method='importance'")
        # The pilot's variance is itself noisy (and low more often than high for skewed
        # samples): SAFETY more, or up to the variance's 90 % upper confidence bound, and never
        # fewer than the pilot.
        self.wanted = int(min(self.max_samples,
                              max(self.min_samples, math.ceil(
                                  max(SAFETY, variance_upper_factor(self.pilot_samples))
                                  * np.nanmax(need)))))
        self.target_n = self.pilot_n + max(2, -(-self.wanted // self.per_sample))
        while len(self.samples) < self.target_n:
            batch = self._tasks(len(self.samples), min(self.target_n, len(self.samples) + width))
            if self._elapsed() + self._expect(len(batch)) > self.max_seconds:
                self.stopped_early = True
                return
            yield from self._timed(batch)
            if self.cut is not None:
                self.stopped_early = True
                return

    def merge(self, task, output):
        # A sample stopped by the deadline is no sample, nor is any after it in its batch
        # (the samples are kept in the order of their indices).
        if self.cut is not None or output.get("timed_out"):
            self.cut = self.cut or output
            return
        self.samples.append(output)
        self.digest.update(_canonical(output))

    def progress(self):
        if self.target_n is None:
            return Progress(len(self.samples), None, "pilot")
        return Progress(len(self.samples), self.target_n)

    def result(self):
        return self.samples


class _LocalReplicas:
    """Splitting replicas [first, last) of a batch run here at once: cut into ``width``
    consecutive groups, one per thread, each run by :func:`samples` with one thread (one group
    alone: here, with the run's ``threads``); the same bits as one at a time. The driver takes
    their outputs in order. They start when the first is asked for."""

    def __init__(self, job, first: int, last: int, deadline, width: int, threads: int) -> None:
        self.job, self.first, self.last = job, first, last
        self.deadline, self.threads = deadline, threads
        count = last - first
        width = max(1, min(width, count))
        cuts = [first + count * g // width for g in range(width + 1)]
        self.groups = [range(a, b) for a, b in zip(cuts, cuts[1:])]
        self.futures = None
        self.outputs: Optional[List[Dict[str, Any]]] = None

    def _start(self) -> None:
        from concurrent.futures import ThreadPoolExecutor

        pool = ThreadPoolExecutor(max_workers=len(self.groups),
                                  thread_name_prefix="crandall-replica")
        self.futures = [pool.submit(samples, self.job, g, 1, self.deadline) for g in self.groups]
        pool.shutdown(wait=False)  # its threads end with their replicas

    def _group(self, i: int) -> int:
        return next(j for j, g in enumerate(self.groups) if i in g)

    def local(self, i: int):
        def run():
            if len(self.groups) == 1:  # here, where Ctrl-C reaches the core
                if self.outputs is None:
                    self.outputs = samples(self.job, self.groups[0], self.threads, self.deadline)
                return self.outputs[i - self.first]
            if self.futures is None:
                self._start()
            j = self._group(i)
            try:
                return self.futures[j].result()[i - self.groups[j].start]
            except BaseException:
                for f in self.futures:  # an error or Ctrl-C: the groups not yet started
                    f.cancel()
                raise
        return run


def _check_memory(paths: int, path_bytes: int, threads: int, name: str, what: str,
                  advice: str) -> None:
    """Refuse, before they are allocated, ``paths`` paths stored whole on a grid of
    ``path_bytes`` each (velocity, displacement, distance at every point), with room for a
    splitting step's copies and scores or importance sampling's touches and excursions (4 x),
    and a stack per thread, that would not fit in what this process may still allocate."""
    need = 4 * paths * path_bytes + threads * (16 << 20)
    have = available_memory()
    if need > have:
        raise ParameterError(
            name, f"{what} of {path_bytes // 24} grid points need about {need / 2**20:.0f} MiB, "
            f"more than the {have / 2**20:.0f} MiB this process may still allocate; {advice}")

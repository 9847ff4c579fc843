"""One driver for every estimator: where its work runs, in what order it is merged, how it is
checkpointed, shown and interrupted.

An estimator (the fixed-step run in :mod:`crandall.simulate`, the run to an accuracy in
:mod:`crandall.adaptive`, the tail probabilities in :mod:`crandall.tail`) only says what to
compute and what to make of it:

- :meth:`Estimator.rounds` is a generator of batches: each batch is a list of :class:`Task`.
  The driver runs a batch's tasks (in this process, or as Dask tasks on a cluster), hands their
  outputs to :meth:`Estimator.merge` in the batch's order, then resumes the generator, which
  looks at what was merged and yields the next batch (or returns). So every decision an
  estimator makes is a function of the merged outputs, in order: the result is bitwise the same
  for any thread count, local or on a cluster, interrupted and resumed or not.
- :meth:`Estimator.identity` is the run's spec as plain data, :meth:`Estimator.state` and
  :meth:`Estimator.restore` its state as named arrays: the driver keeps them in a checkpoint
  (:mod:`crandall.checkpoint`, one format for every estimator), written after merges (at most
  every :attr:`Estimator.checkpoint_seconds`) and at the end of every batch, and read back
  before the first batch; a file of another run is refused naming the field that differs.
- :meth:`Estimator.progress` says how far the run is (done, total or None, a text); the driver
  shows it (``tqdm.auto``: a terminal or a notebook).
- :meth:`Estimator.check_memory` refuses, before anything is allocated, a run that would not
  fit in what this process may still allocate.

The driver owns the rest, once: the local loop and the Dask submission (every task a future,
outputs merged in order as they arrive, several runs at once for a sweep), Ctrl-C (the core
polls it within a fraction of a second; the driver cancels a cluster's futures and keeps what
was merged), the checkpoint and the progress bar. A random stream is never drawn here: every
task's numbers are a function of its arguments (keys from :mod:`crandall.streams`).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from typing import Any, Callable, Dict, Generator, List, NamedTuple, Optional, Tuple

import numpy as np

from . import checkpoint as _ckpt
from ._resources import progress_bar
from .errors import ParameterError
from .spec import check_int

__all__ = ["Task", "Tasks", "Progress", "Estimator", "drive", "check_client", "threads"]


class Task(NamedTuple):
    """One piece of an estimator's work.

    ``function(*args)`` computes the output from plain data (a module-level function: a Dask
    worker runs it). ``local()``, when given, computes the same output in this process (it may
    reuse what the estimator holds, such as a compiled plan); with ``function`` None the task
    always runs here (a step that needs the estimator's state). ``size``: what the task adds to
    the progress (paths, samples). ``key``: what the estimator's merge needs to know of it.
    """

    function: Optional[Callable[..., Any]]
    args: Tuple[Any, ...] = ()
    local: Optional[Callable[[], Any]] = None
    size: int = 0
    key: Any = None

    def run_here(self) -> Any:
        if self.local is not None:
            return self.local()
        return self.function(*self.args)


class Progress(NamedTuple):
    """How far a run is: ``done`` of ``total`` units (None: not known in advance) and a text."""

    done: int = 0
    total: Optional[int] = None
    text: str = ""


Batch = Sequence[Task]


class Tasks(Sequence):
    """A batch of ``count`` tasks made one at a time, ``make(i)`` (so that a batch of very
    many chunks holds no memory per chunk)."""

    def __init__(self, count: int, make: Callable[[int], Task]) -> None:
        self.count, self.make = count, make

    def __len__(self) -> int:
        return self.count

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(self.count))]
        if not 0 <= i < self.count:
            raise IndexError(i)
        return self.make(i)


class Estimator:
    """What the driver runs (see the module's docstring). Subclasses set :attr:`name` (one
    of ``crandall.checkpoint.ESTIMATORS``) and implement :meth:`identity`, :meth:`rounds`,
    :meth:`merge` and :meth:`result`; :meth:`state` and :meth:`restore` for checkpoints."""

    #: The estimator's name in checkpoints' identities.
    name: str = ""
    #: Checkpoint after a merge only if this long has passed since the last write (0: after
    #: every merge); always at the end of a batch.
    checkpoint_seconds: float = 0.0
    #: Threads each Dask task runs with.
    task_threads: int = 1
    #: Set by the driver before :meth:`rounds`: None in this process, the cluster's worker
    #: threads on a cluster (an estimator may cut its work into more, larger tasks there).
    workers: Optional[int] = None

    def identity(self) -> Dict[str, Any]:
        """The run's spec as plain data: what makes two runs the same run."""
        raise NotImplementedError

    def state(self) -> Dict[str, np.ndarray]:
        """The state to resume from, as named arrays (what :meth:`restore` reads)."""
        raise NotImplementedError

    def restore(self, arrays: Dict[str, np.ndarray], path: str) -> None:
        """Carry on from a checkpoint's state (``path`` for messages naming the file)."""
        raise NotImplementedError

    def check_memory(self) -> None:
        """Refuse a run that would not fit in memory (before anything is allocated)."""

    def rounds(self) -> Generator[Batch, None, None]:
        """The batches, each decided from what was merged before it."""
        raise NotImplementedError

    def merge(self, task: Task, output: Any) -> None:
        """Take a task's output (called in each batch's order)."""
        raise NotImplementedError

    def progress(self) -> Progress:
        return Progress()

    def result(self) -> Any:
        raise NotImplementedError


def threads(value) -> Tuple[int, int]:
    """The threads of a run from the user's ``threads``: (threads here, threads per Dask task).
    Default: every core here, one per task (Dask runs a task per worker thread). Results do not
    depend on either."""
    if value is None:
        return os.cpu_count() or 1, 1
    value = check_int("threads", value, 1, 1024)
    return value, value


def check_client(client) -> None:
    """A Dask client, or None: what the driver calls on it must be there."""
    if client is None:
        return
    for attr in ("submit", "nthreads", "cancel"):
        if not callable(getattr(client, attr, None)):
            raise ParameterError("client", f"client must be a distributed.Client (or None), got {client!r}: "
                             f"it has no {attr}()")


def client_threads(client) -> int:
    """The threads of a cluster's workers (a large number if the client cannot say)."""
    try:
        return max(1, sum(client.nthreads().values()))
    except Exception:  # noqa: BLE001 - any client-like object: fall back to many tasks
        return 1 << 30


class _Slot:
    """One estimator under the driver: its generator, current batch, checkpoint."""

    def __init__(self, est: Estimator, checkpoint) -> None:
        self.est = est
        self.checkpoint = checkpoint
        self.ident = None
        self.gen = None
        self.batch: Batch = []
        self.next = 0  # the next task of the batch to merge
        self.last_save = -math.inf
        self.dirty = False
        self.merging = False  # inside merge: the state may be half-updated
        self.checked = False  # the checkpoint's place checked writable

    def open(self) -> None:
        if self.checkpoint is not None:
            self.ident = _ckpt.run_identity(self.est.name, self.est.identity())
            arrays = _ckpt.read(self.checkpoint, self.ident)
            if arrays is not None:
                self.est.restore(arrays, os.fspath(self.checkpoint))
        self.gen = self.est.rounds()

    def advance(self) -> bool:
        """The next batch (False once the estimator is done)."""
        while True:
            try:
                batch = next(self.gen)
            except StopIteration:
                self.save(force=True)
                return False
            self.batch = batch if isinstance(batch, Sequence) else list(batch)
            self.next = 0
            if len(self.batch):
                self.writable()  # fail now, not after the work
                return True
            self.dirty = True  # an empty batch: a point to checkpoint at (the estimator's
            self.save(force=True)  # state moved on without a merge)

    def writable(self) -> None:
        """Check once that the checkpoint can be written (a ValueError naming it)."""
        if self.checkpoint is not None and not self.checked:
            _ckpt.check_writable(self.checkpoint)
            self.checked = True

    def take(self, output) -> None:
        task = self.batch[self.next]
        self.merging = True
        self.est.merge(task, output)
        self.merging = False
        self.next += 1
        self.dirty = True
        self.save(force=self.next == len(self.batch))

    def save(self, force: bool = False) -> None:
        if self.checkpoint is None or not self.dirty or self.merging:
            return
        now = time.perf_counter()
        if not force and now - self.last_save < self.est.checkpoint_seconds:
            return
        self.writable()
        _ckpt.write(self.checkpoint, self.ident, self.est.state())
        self.last_save, self.dirty = now, False


class _Bar:
    """The progress bar of one or more estimators (their progress added up)."""

    def __init__(self, slots: Sequence[_Slot], progress) -> None:
        self.slots = slots
        first = [s.est.progress() for s in slots]
        total = self._total(first)
        self.bar = progress_bar(progress, total=total,
                                initial=sum(p.done for p in first))
        self.total = total

    @staticmethod
    def _total(ps) -> Optional[int]:
        if any(p.total is None for p in ps):
            return None
        return sum(p.total for p in ps)

    def show(self) -> None:
        if self.bar is None:
            return
        ps = [s.est.progress() for s in self.slots]
        total = self._total(ps)
        if total != self.total:
            self.bar.reset(total=total)
            self.total = total
        done = sum(p.done for p in ps)
        if done != self.bar.n:
            self.bar.update(done - self.bar.n)
        text = "; ".join(p.text for p in ps if p.text)
        if text:
            self.bar.set_postfix_str(text, refresh=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def drive(estimators, *, checkpoints=None, client=None, progress=None) -> List[Any]:
    """Run estimators to their end; their results, in order.

    Parameters
    ----------
    estimators : Estimator or sequence of Estimator
        Several (a sweep) run one after the other here; on a cluster every one's batches are
        submitted at once.
    checkpoints : path or sequence of (path or None), optional
        One checkpoint file per estimator (None: none).
    client : distributed.Client, optional
        Run the tasks that have a ``function`` on this cluster; merged in order, so bitwise
        the local result.
    progress : bool, optional
        As :func:`crandall.simulate`'s.
    """
    single = isinstance(estimators, Estimator)
    ests = [estimators] if single else list(estimators)
    if checkpoints is None or isinstance(checkpoints, (str, os.PathLike)):
        checkpoints = [checkpoints] + [None] * (len(ests) - 1)
    check_client(client)
    slots = [_Slot(e, c) for e, c in zip(ests, checkpoints)]
    for s in slots:
        s.est.check_memory()
    for s in slots:
        s.est.workers = None if client is None else client_threads(client)
        s.open()
    bar = _Bar(slots, progress)
    try:
        if client is None:
            for s in slots:
                _run_here(s, bar)
        else:
            _run_on(client, slots, bar)
    finally:
        bar.close()
    return [s.est.result() for s in slots]


def _run_here(slot: _Slot, bar: _Bar) -> None:
    while slot.advance():
        for i in range(len(slot.batch)):
            task = slot.batch[i]
            try:
                output = task.run_here()
            except BaseException:
                slot.save(force=True)  # everything merged so far (a consistent state)
                raise
            slot.take(output)
            bar.show()
        bar.show()
    bar.show()  # the estimator's last word (its final round's text)


def _run_on(client, slots: Sequence[_Slot], bar: _Bar) -> None:
    """Every estimator's current batch submitted at once; each merged in order as its outputs
    arrive; a finished batch's estimator asked for its next one."""
    from distributed import as_completed

    futures: Dict[Any, Tuple[int, int]] = {}  # future -> (slot, task index)
    outputs: List[Dict[int, Any]] = [dict() for _ in slots]
    live = as_completed([])

    def submit(i: int) -> None:
        s = slots[i]
        while s.advance():
            # Tasks that need the estimator's state run here, in order, before the rest.
            while s.next < len(s.batch) and s.batch[s.next].function is None:
                s.take(s.batch[s.next].run_here())
                bar.show()
            if s.next == len(s.batch):
                continue
            for j in range(s.next, len(s.batch)):
                task = s.batch[j]
                if task.function is None:
                    raise ValueError("a batch runs its local-only tasks first")
                fut = client.submit(task.function, *task.args, pure=False)
                futures[fut] = (i, j)
                live.add(fut)
            return

    try:
        for i in range(len(slots)):
            submit(i)
        for fut in live:
            i, j = futures.pop(fut)
            s = slots[i]
            outputs[i][j] = fut.result()
            while s.next in outputs[i]:
                s.take(outputs[i].pop(s.next))
            bar.show()
            if s.next == len(s.batch):
                submit(i)
                bar.show()
    except KeyboardInterrupt:
        client.cancel(list(futures))
        for s in slots:
            s.save(force=True)  # everything merged so far (not a half-done merge)
        raise
    except BaseException:
        client.cancel(list(futures))
        raise

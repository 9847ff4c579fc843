"""``simulate(error=...)``'s run: the statistics and targets checked, an envelope's pieces chosen,
the engine driven."""

from __future__ import annotations

import time
from typing import Optional

from .. import pieces
from ..driver import drive
from ..errors import ParameterError
from ..model import FILTERED_EXCITATION
from ..results import AccuracyResult
from ..scene import Scene
from ..spec import MAX_SEED, check_int, check_positive, check_scene, default_dt
from .estimator import _Engine
from .levels import _check_statistics, _targets, levels_model, MAX_SECONDS
from .schedule import REL_FLOOR


#: Checkpoints of runs to an accuracy (crandall.checkpoint's format, the state a JSON text
#: with a checksum) are replaced atomically at most every CHECKPOINT_SECONDS and at every
#: round's end.
CHECKPOINT_SECONDS = 1.0


def simulate_to_error(scene: Scene, *, error: Optional[float] = None,
                      rel_error: Optional[float] = None, seed: int, threads: int,
                      statistics=None, checkpoint=None, client=None,
                      task_threads: int = 1, progress=None,
                      max_seconds: float = MAX_SECONDS) -> AccuracyResult:
    """Run ``scene`` until every statistic's estimated total error is within the target
    (see :func:`crandall.simulate`)."""
    check_scene(scene, levels_model(scene) if isinstance(scene, Scene) else None,
                "a run to an accuracy (error=, rel_error=)")
    if progress is not None and not isinstance(progress, bool):
        raise ParameterError("progress", f"progress must be True, False or None, got {progress!r}")
    max_seconds = check_positive("max_seconds", max_seconds)
    if (error is None) == (rel_error is None):
        raise ParameterError("error, rel_error", "error: give exactly one of error= and rel_error=")
    eps = check_positive("error", error) if error is not None else None
    rel = check_positive("rel_error", rel_error) if rel_error is not None else None
    seed = check_int("seed", seed, 0, MAX_SEED)
    if "peaks" in scene.observe and FILTERED_EXCITATION not in scene.effects:
        # White noise's levels have no per-path maxima (its kernel records none), so no
        # level could estimate them. A filtered excitation's coupled grids record each grid's
        # maxima per path, and its levels carry them like every other statistic (their bias
        # estimate calibrated against a reference outside the code: bench/filtered_error.py).
        raise ParameterError("observe", "observe: 'peaks' is not available with error= or "
                             "rel_error= under white noise (the peaks are maxima over the "
                             "grid, and the white-noise levels record no per-path maxima to "
                             "estimate their shortfall from); run the peaks with paths=, or "
                             "under a filtered excitation (crandall.KanaiTajimi, "
                             "crandall.CloughPenzien)")
    if scene.distributions:
        raise ParameterError("distributions", "distributions: a run to an accuracy estimates means and variances "
                         "and keeps no histograms; leave distributions out of the scene, or "
                         "run them with paths=")
    if scene.envelope is not None and scene.envelope.function is None:
        # Its piece error, part of every statistic's total error, cannot be estimated: a
        # target could only be claimed met without it.
        raise ParameterError("scene", "scene: its function envelope came back from plain data "
                             "(a saved result, a checkpoint), which keep the pieces, not the "
                             "function, so the piece error a target must include is unknown; "
                             "give envelopes.from_function(...) again")
    chosen = _check_statistics(scene, statistics)
    piece_bias = None
    began = time.perf_counter()
    if scene.envelope is not None:
        # An envelope's pieces, refined until their error (as estimated) is at most half of
        # every target (crandall.pieces); the levels then meet the rest, with the pieces'
        # error counted in each statistic's bias.
        targets = _targets(scene, chosen)
        scene, info = pieces.choose(scene, sorted({t.name for t in targets}),
                                    paths=pieces.PILOT_PATHS, seed=seed, threads=threads,
                                    target=pieces.accuracy_target(scene, eps, rel, REL_FLOOR),
                                    step_length=default_dt(scene),
                                    stats={(t.name, t.stat) for t in targets},
                                    max_seconds=max_seconds)
        if info is not None:
            piece_bias = info["table"]
    engine = _Engine(scene, eps=eps, rel=rel, seed=seed, threads=threads, statistics=chosen)
    if piece_bias is not None:
        engine.piece_bias = [
            float(piece_bias[(t.name, t.stat)][0][t.time_index if t.time_index is not None
                                                  else 0])
            for t in engine.targets]
    engine.max_seconds = max_seconds
    # The pieces' pilot counts against the run's bound.
    engine.pilot_seconds = time.perf_counter() - began if piece_bias is not None else 0.0
    engine.checkpoint = checkpoint
    engine.task_threads = task_threads
    engine.checkpoint_seconds = CHECKPOINT_SECONDS
    return drive(engine, checkpoints=checkpoint, client=client, progress=progress)[0]

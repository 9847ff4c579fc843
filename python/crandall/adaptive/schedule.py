"""The schedule of a run to an accuracy (docs/methods/adaptive.md): estimates, bias and
tolerance per statistic, the rounds of batches per level, and the checkpoint's state
(``_Schedule``, a part of the engine), with the bounds they keep to."""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from typing import Dict, Sequence, Tuple

import numpy as np

from .. import _core, bias, pieces
from ..checkpoint import json_state, read_json_state
from ..driver import Progress
from ..errors import ParameterError
from ..methods import ORDERS
from ..quantities import quantity
from . import levels as _levels
from .levels import _Level, _Sums, FILTER_LEVEL_PILOT, PILOT_PATHS
#: Levels beyond the base (the finest grid is 2^MAX_LEVELS times finer than the base).
MAX_LEVELS = 14
#: Paths a level can draw (its Philox counters run to 2^62).
MAX_LEVEL_PATHS = float(1 << 62)
#: Path-steps per second above any machine's (bench/throughput.py measures tens of millions
#: per thread): a bound for what a pilot must at least cost.
FASTEST_RATE = 1e10
#: A round at most multiplies a level's paths by this (the variance estimates of a small
#: sample can be far off).
MAX_GROWTH = 16


class _Schedule:
    """The schedule of a run to an accuracy: the estimates from the merged sums, the bias and the
    tolerance per statistic, the rounds of batches per level they call for, the progress, and
    the state a checkpoint keeps. A part of :class:`_Engine`."""

    def _drivers(self, asks: Dict[int, float], shown: int = 3) -> str:
        """The statistics that ask for most of the work left (``asks``: path-steps per
        target), for a refusal: each with its time and the share of the work it asks for, and
        what to ask instead."""
        total = sum(asks.values())
        if not total > 0:
            return ""
        # The few that matter (at least 5 % of the work each).
        order = [i for i in sorted(asks, key=lambda i: -asks[i])[:shown]
                 if asks[i] >= 0.05 * total]
        parts = []
        for i in order:
            t = self.targets[i]
            when = "at the stop" if t.time_index is None else (
                f"at {self.scene.time_name} = {self.scene.times[t.time_index]:g}")
            parts.append(f"the {t.stat} of {t.name} {when} ({100 * asks[i] / total:.0f} % "
                         "of the work)")
        names = list(dict.fromkeys(f"{self.targets[i].name}:{self.targets[i].stat}"
                                   for i in order))
        return (f"; most of it is for {', '.join(parts)}: leave {' and '.join(names)} out of "
                "the statistics the target applies to (statistics=, crandall run "
                "--statistics), or ask "
                + ("an absolute error= for " if self.rel is not None else "a larger error= for ")
                + ("it" if len(names) == 1 else "them") + " in a run of its own")

    def _too_long(self, seconds: float, steps: float, what: str, drivers: str = "") -> ValueError:
        """The refusal of a run that would outlast max_seconds: what it would take and what
        would help (``drivers``: the statistics that ask for most of it, :meth:`_drivers`)."""
        elapsed = time.perf_counter() - self.call[0]
        calm = self._calm_time()
        end = self.scene.t0 if "stop" in self.scene.observe else float(self.scene.times.max())
        pause = (f"; {calm:.3g} s of the {end:.3g} s its paths are stepped through have no "
                 f"noise (h = 0), where nothing random happens but the grid's steps still "
                 f"cost" if calm > 0 else "")
        return ValueError(
            f"max_seconds: reaching {self._target_text()} would take about {seconds:.3g} s "
            f"more ({what}: {steps:.3g} path-steps at the times per path measured, "
            f"{elapsed:.3g} s spent), beyond max_seconds={self.max_seconds:g}{pause}{drivers}; "
            f"raise max_seconds or ask for a larger target"
            + (" (the checkpoint keeps what was done)" if self.checkpoint else ""))

    def _calm_time(self) -> float:
        """The time the paths are stepped through without noise (pieces of h = 0)."""
        end = self.scene.t0 if "stop" in self.scene.observe else float(self.scene.times.max())
        pieces = list(self.scene.pieces) if self.scene.pieces is not None else [(self.scene.t0, self.scene.noise)]
        calm, start = 0.0, 0.0
        for stop, noise in pieces:
            if noise == 0:
                calm += max(min(stop, end) - start, 0.0)
            start = stop
        return calm

    def _level(self, level: int) -> _Level:
        while len(self.levels) <= level:
            self.levels.append(_Level(self.scene, len(self.levels), self.seed, self.base_dt,
                                      self.threads, self.integrals, self.quadratic))
            self.levels[-1].siblings = self.levels
            self.levels[-1].batch = self.batch
            if len(self.levels) == 1 and self.use_controls:
                self.levels[0].controls = True
                self.levels[0].control_slots = self.control_slots
        return self.levels[level]

    def _pilot(self, level: int) -> int:
        """A level's pilot paths (and the whole batches it grows by): PILOT_PATHS, but
        FILTER_LEVEL_PILOT on a filtered excitation's levels after the base."""
        return FILTER_LEVEL_PILOT if self.filtered and level > 0 else PILOT_PATHS

    def _pilot_text(self) -> str:
        if self._pilot(1) == PILOT_PATHS:
            return f"{PILOT_PATHS} paths per level"
        return f"{PILOT_PATHS} paths on the base level and {self._pilot(1)} on each finer one"

    def _control_pilot(self) -> int:
        """The paths the base level's control coefficients are fitted on: PILOT_PATHS, or
        after a refit (REFIT_PILOT) a whole batch of at most REFIT_PILOT."""
        return PILOT_PATHS if self.refit is None else min(self.batch, _levels.REFIT_PILOT)

    def _refits(self, want: int) -> bool:
        """Whether the base level refits its control coefficients now (levels.REFIT_PILOT):
        a filtered excitation's, once, when the estimates ask it for at least REFIT_RATIO
        times what the refit costs (the larger pilot and the paths it sets aside), and a batch
        holds several times the first pilot's."""
        # Read from the module at each call (as the checkpoint's identity reads them).
        lev = self.levels[0]
        pilot = min(self.batch, _levels.REFIT_PILOT)
        return (self.filtered and lev.controls and self.beta is not None and self.refit is None
                and pilot >= 4 * PILOT_PATHS
                and want >= _levels.REFIT_RATIO * (pilot + lev.sums.n))

    def _grow(self, level: int, target: int):
        lev = self._level(level)
        have = lev.sums.n if lev.sums is not None else 0
        if lev.controls and self.beta is None:
            # The pilot: coefficients only (the first at path 0, a refit's after the paths
            # set aside).
            yield from self._simulate(lev, lev.start, self._control_pilot())
        if target > have:
            yield from self._simulate(lev, lev.start + have, target - have)

    # -- estimates ------------------------------------------------------------------------

    def estimates(self):
        """Per target: (value, standard error, bias, level variances V_l)."""
        out = []
        for i, t in enumerate(self.targets):
            used = [lev for lev in self.levels if lev.sums is not None and lev.sums.n > 0]
            if t.exact:
                used = used[:1]
            groups = [lev.sums.group(i) for lev in used]
            d = sum(m[0] for m, _ in groups)
            var_d = sum(c[0, 0] / lev.sums.n for (_, c), lev in zip(groups, used))
            if t.stat == "mean" or t.isometry:
                value = self.centre[i] + d
                # A column constant on every path (a quantity identically 0 on a level, an
                # identity's constant) can leave its sum of squares a rounding below 0.
                level_var = [max(c[0, 0], 0.0) for _, c in groups]
                level_mean = [m[0] for m, _ in groups]
            else:
                m2 = sum(m[1] for m, _ in groups)
                # E[d^2] = (E d)^2 + Var d: add Var d back so that the variance is unbiased.
                value = m2 - d * d + var_d
                # The delta method: the estimate moves like the level means of
                # (P - c)^2 - 2 d (P - c).
                level_var = [max(c[1, 1] - 4 * d * c[0, 1] + 4 * d * d * c[0, 0], 0.0)
                             for _, c in groups]
                level_mean = [m[1] - 2 * d * m[0] for m, _ in groups]
            level_se = [math.sqrt(v / lev.sums.n) for v, lev in zip(level_var, used)]
            se = math.sqrt(sum(x * x for x in level_se))
            bias = (0.0 if t.exact else self._measured_bias(level_mean, level_se)
                    if self.filtered else self._bias(level_mean, level_se))
            out.append((value, se, bias, level_var))
        return out

    @staticmethod
    def _bias(level_mean: Sequence[float], level_se: Sequence[float]) -> float:
        """Giles' estimate of the levels left out: the level means fall like 2^(-alpha l), so
        the bias of stopping at level L is about |Y_L| / (2^alpha - 1). alpha is measured from
        the two finest levels when both means are resolved (beyond 2 standard errors), within
        [ALPHA_MIN, ALPHA_MAX]; else ALPHA, the trapezoid rule's leading exponent on this
        skeleton (docs/integrals.md). Then also at least |Y_(L-1)| 2^-alpha / (2^alpha - 1),
        so that a finest mean that is small by chance does not hide the bias."""
        if len(level_mean) < 3:
            return math.inf
        last, prev = abs(level_mean[-1]), abs(level_mean[-2])
        alpha = ALPHA
        if last > 2 * level_se[-1] and prev > 2 * level_se[-2]:
            alpha = min(max(math.log2(prev / last), ALPHA_MIN), ALPHA_MAX)
        return max(last, prev * 2.0 ** -alpha) / (2.0 ** alpha - 1.0)

    @staticmethod
    def _measured_bias(level_mean: Sequence[float], level_se: Sequence[float]) -> float:
        """A filtered excitation's estimate of the levels left out (model.FILTERED_LEVELS),
        with no expansion of its grid bias known: the ratio r = |Y_(L-1)| / |Y_L| of the two
        finest level means is measured where both are resolved (beyond 2 standard errors) and
        kept in [FILTER_RATIO_MIN, 2]; else r = 2 (first order, as crandall.bias assumes for
        a filtered scene's fixed-step bias). The levels left out, falling by r per level, sum
        to max(|Y_L|, |Y_(L-1)| / r) / (r - 1): never a faster decay than first order is
        assumed, and where no decay is seen the factor is 1 / (FILTER_RATIO_MIN - 1) = 10
        (crandall.bias.MAX_ORDER_FACTOR's limit), which sends the run deeper."""
        if len(level_mean) < 3:
            return math.inf
        last, prev = abs(level_mean[-1]), abs(level_mean[-2])
        ratio = 2.0
        if last > 2 * level_se[-1] and prev > 2 * level_se[-2]:
            ratio = min(max(prev / last, FILTER_RATIO_MIN), 2.0)
        return max(last, prev / ratio) / (ratio - 1.0)

    def tolerance(self, i: int, value: float, level_var) -> float:
        """The target of statistic i in the core's variable (the scene asks in the
        quantity's own units: an energy is a factor times its variable)."""
        t = self.targets[i]
        if self.eps is not None:
            f = abs(quantity(t.name).factor(self.scene))
            if f == 0.0:
                return math.inf  # 0 on every path: any target is met
            return self.eps / (f if t.stat == "mean" else f * f)
        scale = abs(value)
        if t.stat == "mean" and level_var:
            # A mean that is 0 by symmetry (velocity, displacement) is measured against the
            # quantity's spread instead.
            scale = max(scale, math.sqrt(max(level_var[0], 0.0)))
        # Never tighter than relative to REL_FLOOR of the statistic's largest value over the
        # output times: a variance when almost every path is at rest is tiny, and its
        # relative error would cost without bound (the crate's velocity variance at 2.75 s
        # asked for 94 % of a run refused as 4.86e4 s).
        return self.rel * max(scale, REL_FLOOR * self.sizes.get((t.name, t.stat), 0.0))

    def _measure_sizes(self, est) -> None:
        """Per (name, stat), the largest scale over the output times (:meth:`tolerance`)."""
        sizes: Dict[Tuple[str, str], float] = {}
        for t, (value, _, _, level_var) in zip(self.targets, est):
            scale = abs(value)
            if t.stat == "mean" and level_var:
                scale = max(scale, math.sqrt(max(level_var[0], 0.0)))
            if math.isfinite(scale):
                key = (t.name, t.stat)
                sizes[key] = max(sizes.get(key, 0.0), scale)
        self.sizes = sizes

    # -- the schedule ---------------------------------------------------------------------

    def _target_text(self) -> str:
        return (f"error={self.eps!r}" if self.eps is not None
                else f"rel_error={self.rel!r}")

    def _unreachable(self, i: int, why: str) -> ValueError:
        t = self.targets[i]
        return ValueError(
            f"{'error' if self.eps is not None else 'rel_error'}: {self._target_text()} "
            f"cannot be reached for the {t.stat} of {t.name}: {why}; ask for a larger one")

    def rounds(self):
        """The schedule to its end (or on from a checkpoint's state), as the driver's
        batches."""
        if self.pending is None:
            # A filtered excitation's velocity has a grid bias too (model.FILTERED_LEVELS).
            deepest = (2 if self.level_targets and (self.integrals or self.filtered) else 0)
            self.pending = [[level, self._pilot(level)] for level in range(deepest + 1)]
            # The first estimate comes after the pilot: a scene whose pilot alone would
            # outlast max_seconds at a rate no machine reaches is refused before it starts.
            pilot = sum(n * self._level(level).cost for level, n in self.pending)
            if pilot / FASTEST_RATE > self.max_seconds:
                raise ParameterError(
                    "max_seconds", f"max_seconds: the pilot alone ({self._pilot_text()}, "
                    f"{pilot:.3g} path-steps) would take at least {pilot / FASTEST_RATE:.3g} s "
                    f"even at {FASTEST_RATE:.0e} path-steps per second, beyond max_seconds="
                    f"{self.max_seconds:g}; give shorter times or t0, or observe only velocity, "
                    "kinetic_energy and stop (no internal steps)")
        started, steps_before = time.perf_counter(), self.path_steps
        self.call = (started, steps_before)
        self.timing = {}
        if self.workers is None:
            # The round in progress (the pilot: many batches on a long grid) as a whole, at
            # its levels' measured times per path; each batch again before it starts.
            seconds = steps = 0.0
            for level, n in self.pending:
                lev = self._level(level)
                have = lev.sums.n if lev.sums is not None else 0
                # A level with control variates fits their coefficients on paths of its own.
                paths = max(n - have, 0) + (self._control_pilot()
                                            if lev.controls and self.beta is None else 0)
                if not paths:
                    continue
                seconds += paths * self.path_seconds(level)
                steps += paths * lev.cost
                # Judged after each level's measurement: a finer level's path costs more.
                if time.perf_counter() - started + seconds > self.max_seconds:
                    raise self._too_long(seconds, steps,
                                         "the round in progress alone" if self.round_count
                                         else f"the pilot alone, {self._pilot_text()}")
        while True:
            while self.pending:
                level, target = self.pending[0]
                yield from self._grow(level, target)
                self.pending.pop(0)
            yield []  # the round's end: a checkpoint
            self.round_count += 1
            est = self.estimates()
            self._measure_sizes(est)
            want = [lev.sums.n for lev in self.levels]
            # Per statistic: the path-steps it alone would still ask for (what a refusal
            # names as driving the cost).
            asks: Dict[int, float] = {}
            done = True
            deeper = False
            worst = 0.0  # the largest error / target, for the progress bar
            for i, (value, se, grid_bias, level_var) in enumerate(est):
                tol = self.tolerance(i, value, level_var)
                if tol == math.inf:
                    continue  # 0 on every path (its factor is 0)
                if not (tol > 0):
                    if value == 0.0 and all(v == 0.0 for v in level_var):
                        continue  # a statistic that is exactly 0 (e.g. at time 0)
                    raise self._unreachable(i, "the target is 0 in doubles")
                # The envelope's pieces' error (crandall.pieces), where the levels can still
                # meet the target beside it (the result reports a target it makes missed).
                piece = self.piece_bias[i] if self.piece_bias is not None else 0.0
                if not piece < tol / 2.0:
                    piece = 0.0
                err2 = se * se + (grid_bias + piece) ** 2
                worst = max(worst, math.sqrt(err2) / tol)
                if err2 > tol * tol:
                    done = False
                if grid_bias + piece > tol / math.sqrt(2.0):
                    deeper = True
                grid_bias += piece
                # Giles' allocation with the variance budget left by the bias (at least half).
                budget = (max(tol * tol - grid_bias * grid_bias, 0.5 * tol * tol)
                          if math.isfinite(grid_bias) else 0.5 * tol * tol)
                costs = [lev.cost for lev in self.levels[:len(level_var)]]
                total = sum(math.sqrt(v * c) for v, c in zip(level_var, costs))
                for level, (v, c) in enumerate(zip(level_var, costs)):
                    if v <= 0:
                        continue
                    x = math.sqrt(v / c) * total / budget if budget > 0 else math.inf
                    if not x < self.max_level_paths:
                        raise self._unreachable(
                            i, f"level {level} would need {x:.3g} paths, beyond the "
                            f"{self.max_level_paths:.3g} a level can draw")
                    want[level] = max(want[level], math.ceil(x))
                    asks[i] = asks.get(i, 0.0) + max(x - self.levels[level].sums.n, 0.0) * c
            if done:
                self._show(worst, 0.0)
                return
            # What the rest is estimated to cost, at the rate measured in this call.
            left = sum(max(n - lev.sums.n, 0) * lev.cost for n, lev in zip(want, self.levels))
            elapsed = time.perf_counter() - started
            ran = self.path_steps - steps_before
            # No rate yet when a resumed run starts at a round's end: judged next round.
            seconds = left * elapsed / ran if ran > 0 else math.nan
            if self.workers is None and ran > 0:
                # Here: at each level's own time per path (a path's cost is not its steps
                # alone: see timing).
                seconds = sum(max(n - lev.sums.n, 0) * self.path_seconds(lev.level)
                              for n, lev in zip(want, self.levels))
            self._show(worst, seconds)
            if self.pilot_seconds + elapsed + seconds > self.max_seconds:
                raise self._too_long(seconds, left, f"after {self.round_count} rounds",
                                     self._drivers(asks))
            if deeper and len(self.levels) <= MAX_LEVELS:
                self.pending = [[len(self.levels), self._pilot(len(self.levels))]]
                continue
            if deeper:
                raise ParameterError(
                    "error", f"error: the discretisation bias is still above the target on a grid "
                    f"2^{MAX_LEVELS} times finer than the base; ask for a larger error")
            self.pending = []
            for level, n in enumerate(want):
                have = self.levels[level].sums.n
                n = min(n, have * MAX_GROWTH)
                # Whole batches beyond the pilot, so that small increments do not cost a call.
                unit = self._pilot(level)
                n = -(-n // unit) * unit
                if n > have:
                    self.pending.append([level, n])
            if self._refits(want[0]):
                # The base level's estimate so far is set aside (its paths stay counted in
                # path_steps), the coefficients are fitted again on the next paths, and the
                # estimate starts again after them with a batch as large as that pilot.
                base = self.levels[0]
                self.refit = base.sums.n
                base.start += base.sums.n
                base.sums = None
                self.beta = None
                self.pending = [[0, self._control_pilot()]] + [p for p in self.pending
                                                              if p[0] != 0]

    def _show(self, worst: float, seconds: float) -> None:
        left = ("done" if seconds == 0 else "estimating" if math.isnan(seconds)
                else f"about {seconds:.3g} s left")
        self.text = f"round {self.round_count}, error/target {worst:.3g}, {left}"

    def progress(self) -> Progress:
        return Progress(text=self.text)

    def _state(self) -> Dict:
        return {"centre": None if self.centre is None else [float(c) for c in self.centre],
                "beta": self.beta, "refit": self.refit, "path_steps": self.path_steps,
                "rounds": self.round_count,
                "wall_time": self.wall_before + (time.perf_counter() - self.started),
                "pending": self.pending,
                "levels": [{"start": lev.start, "n": 0 if lev.sums is None else lev.sums.n,
                            "flat": None if lev.sums is None else [float(v) for v in lev.sums.flat]}
                           for lev in self.levels]}

    def state(self) -> Dict[str, np.ndarray]:
        """The state as one JSON text (floats written exactly, as Python's repr round-trips
        them) with its checksum."""
        st = self._state()
        st["checksum"] = _checksum(st)
        return json_state(st)

    def restore(self, arrays: Dict[str, np.ndarray], path) -> None:
        """Carry on from a checkpoint's state (its identity already matched this run's)."""
        where = f"checkpoint: {os.fspath(path)}"
        st = read_json_state(path, arrays, "a run to an accuracy")
        # Every edit is refused, even one that keeps the fields consistent with each other (a
        # level's path count and its sums changed together): the file is the run's own only
        # if its checksum matches.
        if st.get("checksum") != _checksum({k: v for k, v in st.items() if k != "checksum"}):
            raise ValueError(f"{where} is damaged (field checksum: it does not match the "
                             "contents, which were edited or damaged); remove it to start again")
        try:
            self._restore_fields(st)
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            field = exc.args[0] if isinstance(exc, (KeyError, ValueError)) and exc.args else exc
            raise ValueError(f"{where} is damaged (field {field})") from None

    def _restore_fields(self, st: Dict) -> None:
        """The state's fields, each checked against what a run can have written (a
        ValueError whose argument names the field)."""
        levels = st["levels"]
        if not isinstance(levels, list) or len(levels) > MAX_LEVELS + 1:
            raise ValueError(f"levels: {MAX_LEVELS + 1} at most")
        # The base level's estimation paths a refit set aside (absent before refits were).
        refit = st.get("refit")
        if refit is not None:
            refit = _nonneg_int(refit, "refit")
            if not self.filtered or refit > self.max_level_paths:
                raise ValueError("refit")
        self.refit = refit
        first = min(self.batch, PILOT_PATHS)
        steps = 0
        for k, lv in enumerate(levels):
            lev = self._level(k)
            start = _nonneg_int(lv["start"], f"levels[{k}].start")
            # Only the base level leaves paths out: the first batch of its pilot; after a
            # refit, the paths it set aside and (once run) its pilot.
            allowed = ((0,) if k else (0, first) if refit is None
                       else (first + refit, first + refit + self._control_pilot()))
            if start not in allowed:
                raise ValueError(f"levels[{k}].start")
            n = _nonneg_int(lv["n"], f"levels[{k}].n")
            if n > self.max_level_paths:
                raise ValueError(f"levels[{k}].n")
            lev.start = start
            if lv["flat"] is not None:
                flat = np.array(lv["flat"], dtype=float)
                if flat.shape != (self.sums_width,) or not np.all(np.isfinite(flat)) or n < 1:
                    raise ValueError(f"levels[{k}].flat")
                lev.sums = _Sums(self.widths)
                lev.sums.add(n, flat)
            elif n != 0:
                raise ValueError(f"levels[{k}].n")
            steps += (start + n) * lev.cost
        if st["centre"] is not None:
            centre = np.array(st["centre"], dtype=float)
            if centre.shape != (len(self.targets),) or not np.all(np.isfinite(centre)):
                raise ValueError("centre")
            self.centre = centre
        if st["beta"] is not None:
            beta = [[float(v) for v in row] for row in st["beta"]]
            if not self.filtered:
                # The white kernel's controls, as a checkpoint written when the row was
                # narrower has them (only them, or them and zeros: 15 or 18 wide): the rest of
                # the row is 0, and so are their coefficients.
                beta = [r + [0.0] * (_core.CONTROLS - len(r))
                        if _core.WHITE_CONTROLS <= len(r) < _core.CONTROLS
                        and not any(r[_core.WHITE_CONTROLS:]) else r for r in beta]
            if len(beta) != len(self.cols) or any(len(r) != _core.CONTROLS for r in beta) \
                    or not all(math.isfinite(v) for r in beta for v in r):
                raise ValueError("beta")
            self.beta = beta
        # Every path a level drew, pilot included, was counted at that level's steps.
        self.path_steps = _nonneg_int(st["path_steps"], "path_steps")
        if self.path_steps != steps:
            raise ValueError("path_steps")
        self.round_count = _nonneg_int(st["rounds"], "rounds")
        wall = st["wall_time"]
        if isinstance(wall, bool) or not isinstance(wall, (int, float)) \
                or not (math.isfinite(wall) and wall >= 0):
            raise ValueError("wall_time")
        self.wall_before = float(wall)
        pending = st["pending"]
        if pending is not None:
            pending = [[_nonneg_int(a, "pending"), _nonneg_int(b, "pending")]
                       for a, b in pending]
            if any(a > MAX_LEVELS or b > self.max_level_paths for a, b in pending):
                raise ValueError("pending")
        self.pending = pending


def _checksum(state: Dict) -> str:
    """SHA-256 of the state as canonical JSON (keys sorted; floats as Python writes them,
    which round-trip exactly)."""
    text = json.dumps(state, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _nonneg_int(value, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(field)
    return value


#: rel_error is relative to a statistic's value, or to this fraction of its largest value
#: over the output times where that is larger (docs/methods/adaptive.md).
REL_FLOOR = 0.01


#: The exponent of the level means' decay assumed by the bias estimate where it is not
#: resolved, and the range a measured one is kept in (docs/methods/adaptive.md). The levels
#: are the exact method's grids (adaptive.levels), so it is that method's order in the core's
#: table (crandall.methods.ORDERS: 1.5, the trapezoid rule's leading exponent).
ALPHA = ORDERS["exact"]
ALPHA_MIN, ALPHA_MAX = 1.0, 3.0
#: The smallest ratio of successive level means a filtered excitation's bias estimate takes
#: (_Schedule._measured_bias).
FILTER_RATIO_MIN = 1.1

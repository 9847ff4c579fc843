"""The control variates' features: which output slots carry control sums (``CONTROL_SLOTS``)
and the engine's part that builds and fits them (``_Features``)."""

from __future__ import annotations

from typing import Dict, List, Optional, Tuple

import numpy as np

from .. import _core
from ..quantities import VELOCITY
from ..model import ito_constant
from ..scene import Scene
from .levels import _moments, _solve_many
#: Bytes of the matrices that fit the control coefficients, per call of the core.
FIT_BYTES = 32 << 20
#: Output slots that carry control sums: every slot up to this many; beyond, this many slots
#: spread over the output times, each column using the nearest one's (any slot's sums have
#: mean 0, so any choice stays unbiased). The sums cost work per step and slot, so with
#: thousands of output times they cost more than the paths (docs/methods/adaptive.md).
CONTROL_SLOTS = 64


def _control_slots(scene: Scene, slots: int) -> Tuple[List[int], List[int]]:
    """The slots that carry control sums (every slot, or CONTROL_SLOTS of them spread evenly
    over the slot indices, the last slot among them) and, per slot, the index among them of
    the one whose sums it uses: the nearest in the time its sums run to (its output time, at
    most the switch-off; the stop's: the switch-off), ties to the later one."""
    if slots <= CONTROL_SLOTS:
        return list(range(slots)), list(range(slots))
    chosen = sorted({round(i * (slots - 1) / (CONTROL_SLOTS - 1)) for i in range(CONTROL_SLOTS)})
    until = np.full(slots, scene.t0, dtype=float)
    until[:len(scene.times)] = np.minimum(scene.times, scene.t0)
    gap = np.abs(until[:, None] - until[None, chosen])
    # The last of the nearest: argmin of the reversed columns.
    nearest = len(chosen) - 1 - np.argmin(gap[:, ::-1], axis=1)
    return chosen, [int(a) for a in nearest]


class _Features:
    """The control variates of a run to an accuracy: the columns of the targets and controls the
    core sums per path, and the fitted coefficients (``centre``, ``beta``). A part of
    :class:`_Engine`."""

    # -- per-path values ------------------------------------------------------------------

    # The centring constants and the control coefficients: setting either renews the feature
    # columns handed to the core.
    @property
    def centre(self) -> Optional[np.ndarray]:
        return self._centre

    @centre.setter
    def centre(self, value: Optional[np.ndarray]) -> None:
        self._centre = value
        self._columns_cache = None

    @property
    def beta(self) -> Optional[List[List[float]]]:
        return self._beta

    @beta.setter
    def beta(self, value: Optional[List[List[float]]]) -> None:
        self._beta = value
        self._columns_cache = None

    def _target_columns(self) -> "_core.FeatureColumns":
        """One column per target: how its per-path value is formed from the samples (its slot
        and variable; the value itself, the stop time from the switch-off included; its
        square; the mean distance's Ito identity (sigma^2 elapsed - V^2) / (2 c), with V = 0
        at the stop; or the isometry's int sigma^2 V^2 dt / c^2), with centre 0 and power 1."""
        if self._targets_cache is None:
            sc = self.scene
            c = _core.FeatureColumns()
            kind, const = [], []
            for t in self.targets:
                if t.ito:
                    kind.append(2 if t.time_index is not None else 3)
                    elapsed = (min(sc.times[t.time_index], sc.t0) if t.time_index is not None
                               else sc.t0)
                    const.append(ito_constant(sc, elapsed))
                elif t.isometry:
                    kind.append(5)
                    const.append(1.0 / (sc.drift * sc.drift))
                else:
                    first = t.power == 1 or (t.stat == "mean" and t.variable == VELOCITY
                                             and t.time_index is None)
                    kind.append(4 if t.magnitude else 0 if first else 1)
                    const.append(0.0)
            c.slot = [t.slot for t in self.targets]
            c.variable = [VELOCITY if t.ito or t.isometry else t.variable
                          for t in self.targets]
            c.kind, c.constant = kind, const
            c.power = [1] * len(self.targets)
            c.centre = [0.0] * len(self.targets)
            c.inexact = [int(not t.exact) for t in self.targets]
            self._targets_cache = c
        return self._targets_cache

    def _columns(self) -> "_core.FeatureColumns":
        """The feature columns: per column its target's value minus the target's centre, to
        the column's power; with the control coefficients once fitted."""
        if self._columns_cache is None:
            per_target = self._target_columns()
            c = _core.FeatureColumns()
            which = [i for i, _ in self.cols]
            for field in ("slot", "variable", "kind", "constant", "inexact"):
                values = getattr(per_target, field)
                setattr(c, field, [values[i] for i in which])
            c.power = [p for _, p in self.cols]
            c.centre = [float(self.centre[i]) for i in which]
            if self.beta is not None:
                c.control = [self.control_of[self.targets[i].slot] for i in which]
                c.beta = [b for row in self.beta for b in row]
            self._columns_cache = c
        return self._columns_cache

    def _values(self, block: np.ndarray) -> np.ndarray:
        """Every target's per-path value on the fine grid, one column each."""
        out = np.empty((block.shape[0], len(self.targets)))
        return _core.form_features(block, self._target_columns(), 2.0 * self.scene.drift, 0,
                                   out, None, self.threads)

    def _features(self, block: np.ndarray, level: int,
                  controls: Optional[np.ndarray] = None) -> np.ndarray:
        """The feature columns of a batch (formed in the core, into a buffer kept between
        batches): on the base level minus the controls' multiples once their coefficients
        are fitted (mean exactly 0: still unbiased), on a finer level the fine grid's minus
        the coarse grid's."""
        n = block.shape[0]
        if self._feature_buffer is None or self._feature_buffer.shape[0] < n:
            self._feature_buffer = np.empty((max(n, self.batch), len(self.cols)))
        out = self._feature_buffer[:n]
        use = controls if (level == 0 and controls is not None and self.beta is not None) else None
        return _core.form_features(block, self._columns(), 2.0 * self.scene.drift, level, out,
                                   use, self.threads)

    def _fit_controls(self, block: np.ndarray, controls: np.ndarray) -> None:
        """The control coefficients of every feature column: least squares on the pilot paths
        (which the estimates then leave out, so that the coefficients are independent of the
        paths they are applied to)."""
        raw = self._features(block, 0)
        # The controls the plan's kernel fills (the white kernel leaves the rest of a row 0):
        # only they are fitted, and the rest of each column's coefficients are 0.
        n = len(raw)
        k = controls.shape[2] if self.filtered else _core.WHITE_CONTROLS
        width = k + 1
        flat_width = width + width * (width + 1) // 2
        # Many columns' [feature, controls of its slot] in one call: each group's sums are
        # accumulated on their own, so they are the bits of a call per column.
        per_call = max(1, FIT_BYTES // (8 * n * width))
        anchor = np.array([self.control_of[self.targets[i].slot] for i, _ in self.cols],
                          dtype=np.intp)
        covs = np.empty((len(self.cols), width, width))
        m = np.empty((n, min(per_call, len(self.cols)), width))
        for start in range(0, len(self.cols), per_call):
            stop = min(start + per_call, len(self.cols))
            g = m[:, :stop - start]
            g[:, :, 0] = raw[:, start:stop]
            g[:, :, 1:] = controls[:, anchor[start:stop], :k]
            flat = _core.sum_products(np.ascontiguousarray(g.reshape(n, -1)),
                                      [width] * (stop - start), self.threads)
            # As a level's sums would hold them (0 plus the sums), then their covariances.
            flat = 0.0 + flat.reshape(stop - start, flat_width)
            covs[start:stop] = _moments(flat, n, width)[1]
        # The controls' covariance is the same for every column that uses a slot's sums:
        # one elimination per such slot, every column's right-hand side through it.
        by_slot: Dict[int, List[int]] = {}
        for c, a in enumerate(anchor.tolist()):
            by_slot.setdefault(a, []).append(c)
        beta = [None] * len(self.cols)
        for cs in by_slot.values():
            xs = _solve_many(covs[cs[0]][1:, 1:], covs[cs, 1:, 0])
            for c, x in zip(cs, xs):
                beta[c] = list(x) + [0.0] * (controls.shape[2] - k)
        self.beta = beta

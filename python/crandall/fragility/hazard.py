"""The lognormal fit's and the hazard's results (:class:`LognormalFit`, :class:`Hazard`), a
site's hazard curve (read from a file or given as arrays), the hazard table and the fine grid
the hazard integral runs on."""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np

from ..errors import ParameterError
from .grid import _grid


@dataclass
class LognormalFit:
    """Per threshold, the lognormal fragility curve P = Phi(s ln(x / median) / beta) (s = +1 over
    intensities, -1 over mu: P falls as the friction grows), fitted by
    :meth:`FragilityResult.fit_lognormal`. ``covariance[k]`` is that of (ln median, beta);
    ``chi2`` and ``dof`` the fit's weighted sum of squares and its degrees of freedom; ``points``
    how many grid points entered (NaN fits where fewer than 2 did)."""

    thresholds: np.ndarray
    median: np.ndarray
    median_stderr: np.ndarray
    median_low: np.ndarray
    median_high: np.ndarray
    beta: np.ndarray
    beta_stderr: np.ndarray
    beta_low: np.ndarray
    beta_high: np.ndarray
    covariance: np.ndarray
    chi2: np.ndarray
    dof: np.ndarray
    points: np.ndarray
    sign: float = 1.0

    def probability(self, x, k: int = 0) -> np.ndarray:
        """The fitted curve of threshold ``k`` at ``x``."""
        from scipy.special import ndtr

        x = np.asarray(x, dtype=float)
        return ndtr(self.sign * (np.log(x) - math.log(self.median[k])) / self.beta[k])

    def __str__(self) -> str:
        lines = [f"{'threshold':>12} {'median':>11} {'95% interval':>23} {'beta':>8} "
                 f"{'95% interval':>19} {'chi2/dof':>9}"]
        for k, d in enumerate(self.thresholds):
            dof = int(self.dof[k])
            fit = f"{self.chi2[k] / dof:9.2f}" if dof > 0 else f"{'-':>9}"
            lines.append(f"{d:12.6g} {self.median[k]:11.4g} [{self.median_low[k]:9.4g}, "
                         f"{self.median_high[k]:9.4g}] {self.beta[k]:8.4f} "
                         f"[{self.beta_low[k]:7.4f}, {self.beta_high[k]:7.4f}] {fit}")
        return "\n".join(lines)


@dataclass
class Hazard:
    """The annual rate of exceeding each threshold, with its standard error and 95 % interval
    (:meth:`FragilityResult.hazard`)."""

    thresholds: np.ndarray
    rate: np.ndarray
    stderr: np.ndarray
    low: np.ndarray
    high: np.ndarray
    #: With ``use="estimates"``: the most the shaking outside the grid could add (its part
    #: below the grid is left out, above it counted with P at the grid's end); 0 for the fit.
    outside: Optional[np.ndarray] = None
    #: "fit" or "estimates" (:meth:`FragilityResult.hazard`).
    use: str = "fit"

    def __str__(self) -> str:
        lines = [f"annual rate of exceedance ({'the lognormal fit' if self.use == 'fit' else 'the grid estimates'})",
                 f"{'threshold':>12} {'rate / yr':>11} {'stderr':>10} {'95% interval':>23}"
                 + (f" {'outside grid, up to':>20}" if self.use == "estimates" else "")]
        for k, d in enumerate(self.thresholds):
            extra = f" {self.outside[k]:20.3g}" if self.use == "estimates" else ""
            lines.append(f"{d:12.6g} {self.rate[k]:11.4g} {self.stderr[k]:10.3g} "
                         f"[{self.low[k]:9.4g}, {self.high[k]:9.4g}]{extra}")
        return "\n".join(lines)


def _hazard_curve(curve) -> Tuple[np.ndarray, np.ndarray]:
    try:
        im, rate = curve
    except (TypeError, ValueError):
        raise ParameterError("curve", "curve must be two arrays (intensities, annual rates of "
                                      "exceeding each)") from None
    im = _grid("curve", im)
    try:
        rate = np.asarray(rate, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError("curve", "curve: the rates must be numbers") from None
    if rate.shape != im.shape:
        raise ParameterError("curve", f"curve: {im.size} intensities but {rate.size} rates")
    if not (np.isfinite(rate).all() and (rate > 0).all()):
        raise ParameterError("curve", "curve: the rates must be finite and > 0")
    if im.size < 2 or (np.diff(rate) > 0).any():
        raise ParameterError("curve", "curve: at least two points, the rates non-increasing "
                                      "(a rate of exceedance falls as the intensity grows)")
    return im, rate


def read_hazard_curve(path: Union[str, "os.PathLike[str]"]) -> Tuple[np.ndarray, np.ndarray]:
    """A hazard curve from a text file: two columns, the intensity (increasing) and the annual
    rate of shaking stronger than it (non-increasing), separated by a comma, semicolon or
    blanks; blank lines, lines starting with ``#`` and one header line (the first line that
    is not numbers) skipped. Checked as :meth:`FragilityResult.hazard` checks a curve.

    Raises
    ------
    ParameterError
        Naming ``hazard``: an unreadable file, a line that is not two numbers, too few
        points, intensities not increasing or rates not non-increasing, not finite or <= 0.
    """
    p = os.fspath(path)
    try:
        with open(p, encoding="utf-8-sig") as f:
            lines = f.read().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ParameterError("hazard", f"hazard: cannot read {p!r}: "
                                       f"{getattr(exc, 'strerror', None) or exc}") from None
    rows: List[Tuple[float, float]] = []
    header = False
    for number, line in enumerate(lines, 1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        cells = [c for c in re.split(r"[,;\s]+", text) if c]
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if not rows and not header:
                header = True
                continue
            raise ParameterError("hazard", f"hazard: {p!r} line {number} is not numbers: "
                                           f"{text[:60]!r}") from None
        if len(values) != 2:
            raise ParameterError("hazard", f"hazard: {p!r} line {number} has {len(values)} "
                                           f"columns; give two (intensity, annual rate)")
        rows.append((values[0], values[1]))
    if not rows:
        raise ParameterError("hazard", f"hazard: {p!r} holds no (intensity, rate) lines")
    im, rate = np.array(rows).T
    try:
        return _hazard_curve((im, rate))
    except ParameterError as exc:
        raise ParameterError("hazard", f"hazard: {p!r}: {exc}") from None


def hazard_csv(hazards: Sequence[Hazard], units: str = "", by: Optional[str] = None,
               by_values: Optional[np.ndarray] = None) -> str:
    """The annual rates as CSV text: a row per threshold (and value of ``by``, a column before
    it, for the hazards of a grid over two axes): threshold, rate, stderr, the 95 % interval
    and, with ``use="estimates"``, the most the shaking outside the grid could add."""
    unit = f" [{units}]" if units else ""
    cols = ([by] if by else []) + [f"threshold{unit}", "rate [1/yr]", "stderr [1/yr]",
                                   "low [1/yr]", "high [1/yr]", "outside [1/yr]"]
    out = ["# annual rate of exceeding each threshold, 95 % intervals; through "
           + ("the lognormal fit" if hazards[0].use == "fit" else "the grid estimates"),
           ",".join(cols)]
    for j, hz in enumerate(hazards):
        lead = [] if by is None else [repr(float(by_values[j]))]
        for k, d in enumerate(hz.thresholds):
            extra = hz.outside[k] if hz.outside is not None else 0.0
            out.append(",".join(lead + [repr(float(v)) for v in
                                        (d, hz.rate[k], hz.stderr[k], hz.low[k], hz.high[k],
                                         extra)]))
    return "\n".join(out) + "\n"


#: The hazard integral's largest sub-grid step in ln x (the trapezoid rule's relative error
#: is then about 1e-5 for a power law of exponent 2.5: tests/test_fragility.py).
_HAZARD_STEP = 0.002


def _sub_grid(lx, lr, lo, hi, extra=()):
    """ln x on [lo, hi] in steps of at most _HAZARD_STEP through every point of ``lx`` and
    ``extra`` inside, and lambda there (interpolated linearly in (ln x, ln lambda))."""
    knots = np.unique(np.concatenate([[lo, hi], lx[(lx > lo) & (lx < hi)],
                                      np.asarray(extra, dtype=float)[(np.asarray(extra) > lo)
                                                                     & (np.asarray(extra) < hi)]]))
    pieces = [np.linspace(a, b, max(1, int(math.ceil((b - a) / _HAZARD_STEP))) + 1)[:-1]
              for a, b in zip(knots[:-1], knots[1:])]
    sub = np.concatenate(pieces + [knots[-1:]])
    return sub, np.exp(np.interp(sub, lx, lr))

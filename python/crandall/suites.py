"""Fragility over a suite of recorded ground motions: the weighted fraction of records whose
Newmark displacement exceeds each threshold, per yield value and, with the records scaled to
a list of peak ground accelerations, per PGA (docs/records.md, docs/fragility.md).

The displacements are one :func:`crandall.newmark` sweep (records x yields x polarities in
the compiled core). The result is a :class:`crandall.FragilityResult` (its table, files,
figure, hazard), with its own lognormal fit (binomial maximum likelihood) and an interval for
a weighted fraction: Clopper-Pearson on Kish's effective sample size.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .errors import ParameterError
from .fragility import _SIGN, _Z95, FragilityResult, LognormalFit, _grid
from .records import Record, newmark

__all__ = ["record_fragility", "RecordFragilityResult", "MEASURES", "RECORD_AXES",
           "effective_size", "weighted_interval"]

#: A record suite's axes: the PGA the records are scaled to (g), or the yield swept (g):
#: ky (one-way), mu (flat, two-way), kd (an incline's downslope yield).
RECORD_AXES = ("pga", "ky", "mu", "kd")

#: What is compared with the thresholds: |displacement at the record's end|, or the largest
#: |displacement| over the record (the same for one-way sliding, which never goes back).
MEASURES = ("displacement", "peak_displacement")


def effective_size(weights) -> float:
    """Kish's effective sample size (sum w)^2 / sum w^2 of non-negative weights (n for equal
    ones; fewer the more unequal they are)."""
    w = np.asarray(weights, dtype=float)
    w = w / w.sum()
    return float(1.0 / np.sum(w * w))


def weighted_interval(fraction, n_eff: float, level: float = 0.95) -> Tuple[np.ndarray, np.ndarray]:
    """The Clopper-Pearson interval of a fraction ``fraction`` of ``n_eff`` trials at
    confidence ``level``, with x = fraction n_eff successes (not necessarily an integer: the
    beta quantiles take any x): low = B(a/2; x, n - x + 1) (0 at x = 0), high = B(1 - a/2;
    x + 1, n - x) (1 at x = n). For equal weights (n_eff = n, x an integer) its coverage is at
    least ``level`` for every true fraction."""
    from scipy.stats import beta

    p = np.asarray(fraction, dtype=float)
    x = p * n_eff
    a = 1.0 - level
    with np.errstate(invalid="ignore", divide="ignore"):
        low = np.where(x > 0, beta.ppf(a / 2, np.maximum(x, 1e-300), n_eff - x + 1), 0.0)
        high = np.where(x < n_eff, beta.ppf(1 - a / 2, x + 1, np.maximum(n_eff - x, 1e-300)), 1.0)
    return low, high


def _records(records) -> List[Record]:
    if isinstance(records, Record):
        return [records]
    if isinstance(records, (list, tuple)) and records and all(isinstance(r, Record)
                                                              for r in records):
        return list(records)
    raise ParameterError("records", "records must be a crandall.Record or a non-empty list of "
                                    f"them, got {type(records).__name__}")


def _weights(weights, n: int) -> np.ndarray:
    if weights is None:
        return np.ones(n)
    if isinstance(weights, (str, bytes)):
        raise ParameterError("weights", "weights must be a sequence of numbers, got a string")
    try:
        w = np.array(weights, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError("weights", "weights must be a sequence of numbers") from None
    if w.shape != (n,):
        raise ParameterError("weights", f"weights: one per record ({n}), got shape {w.shape}")
    if not (np.isfinite(w).all() and (w >= 0).all() and w.sum() > 0):
        raise ParameterError("weights", "weights must be finite and >= 0, not all 0")
    return w


def record_fragility(records, thresholds, *, ky=None, mu=None, mu_static=None, kd=None,
                     ku=None, pga=None, weights=None, polarity: str = "both",
                     measure: str = "displacement", method: str = "exact",
                     threads: Optional[int] = None) -> "RecordFragilityResult":
    """P(D > d) over a suite of records: the weighted fraction of records whose Newmark
    displacement exceeds each threshold d, per yield value and, with ``pga``, per level of
    peak ground acceleration the records are scaled to.

    Parameters
    ----------
    records : Record or list of Record
        The suite (each record as given, or scaled to each ``pga``).
    thresholds : sequence of float
        Displacements, m: strictly increasing, > 0.
    ky, mu, mu_static, kd, ku : float or sequence
        The block, as for :func:`crandall.newmark` (in g). An array of ``ky``, ``mu`` or ``kd``
        is an axis of the result.
    pga : sequence of float, optional
        Scale every record to each of these peak ground accelerations (g; ``Record.scaled``),
        an axis of the result (the first: a curve over PGA per yield value).
    weights : sequence of float, optional
        One per record, >= 0 (default: equal). The fraction is sum w_r y_r / sum w_r.
    polarity : {"both", "normal", "inverse"}
        "both" (default): each record counts in both polarities, half its weight each, so a
        record exceeding d in one of them counts y_r = 1/2 (the record, not the polarity, is
        the independent unit: the interval's effective size counts records).
    measure : {"displacement", "peak_displacement"}
        |the displacement at the record's end| (default) or the largest |displacement| over
        the record.
    method, threads
        As for :func:`crandall.newmark`.

    Returns
    -------
    RecordFragilityResult
        The fraction, its standard error sqrt(p (1 - p) / n_eff) and its 95 % interval
        (Clopper-Pearson at x = p n_eff of n_eff, Kish's effective size (sum w)^2 / sum w^2);
        every record's displacement.
    """
    recs = _records(records)
    thr = _grid("thresholds", thresholds)
    w = _weights(weights, len(recs))
    if measure not in MEASURES:
        raise ParameterError("measure", f"measure must be one of {', '.join(MEASURES)}, got "
                                        f"{measure!r}")
    levels = None if pga is None else _grid("pga", pga)
    start = time.perf_counter()
    suite = recs if levels is None else [r.scaled(pga=x) for x in levels for r in recs]
    res = newmark(suite, ky=ky, mu=mu, mu_static=mu_static, kd=kd, ku=ku, polarity=polarity,
                  method=method, threads=threads)
    seconds = time.perf_counter() - start
    name = {"one-way": "ky", "flat": "mu", "incline": "kd"}[res.mode]
    swept = "yield" in res.dims
    table = res.table.reshape((1 if levels is None else len(levels), len(recs))
                              + res.table.shape[1:])
    if measure == "displacement":
        disp = np.abs(table[..., 0])
    else:
        disp = np.maximum(table[..., 1], -table[..., 2])
    disp = np.moveaxis(disp, 1, 0)   # (record, pga, yield, polarity)
    if levels is None:
        disp = disp[:, 0]
        axis, values, by, by_values = name, res.yields[name], None, None
    elif swept:
        axis, values, by, by_values = "pga", levels, name, res.yields[name]
    else:
        disp = disp[:, :, 0]
        axis, values, by, by_values = "pga", levels, None, None
    out = _fractions(disp, thr, w)
    return RecordFragilityResult(
        quantity=measure, axis=axis, values=values, by=by, by_values=by_values,
        thresholds=thr, units="m", run=np.zeros(disp.shape[1:-1], dtype=np.int64),
        shared=True, seed=None, scene={}, seconds=seconds, steps=0, method=method,
        rel_error_target=0.0, records=[r.name for r in recs],
        record_pga=np.array([r.pga for r in recs]), weights=w,
        displacement=disp, polarities=tuple(res.polarities), mode=res.mode,
        yields={k: v.tolist() for k, v in res.yields.items()}, **out)


def _fractions(disp: np.ndarray, thr: np.ndarray, w: np.ndarray) -> Dict[str, Any]:
    """The weighted fractions over the grid from the displacements (record, grid..., polarity):
    y_r the fraction of the record's polarities above d, p = sum w y / sum w."""
    y = (disp[..., None] > thr).mean(axis=-2)           # (record, grid..., threshold)
    p = np.tensordot(w / w.sum(), y, axes=(0, 0))
    p = np.clip(p, 0.0, 1.0)   # a sum of weights 1 - 1e-16: no fraction above 1
    n_eff = effective_size(w)
    low, high = weighted_interval(p, n_eff)
    return dict(probability=p, stderr=np.sqrt(p * (1.0 - p) / n_eff), low=low, high=high,
                reliable=np.ones(p.shape, dtype=bool))


@dataclass
class RecordFragilityResult(FragilityResult):
    """P(D > d) over a suite of records (:func:`crandall.record_fragility`): a
    :class:`FragilityResult` over PGA and/or a yield (``axis`` "pga", "ky", "mu" or "kd";
    ``by`` the yield when both), whose probability is the weighted fraction of records and
    whose interval is Clopper-Pearson on Kish's effective size.

    Attributes (beside FragilityResult's)
    -------------------------------------
    records, record_pga, weights
        The records' names, their PGA as given (g) and weights.
    n_eff : float
        Kish's effective size (sum w)^2 / sum w^2.
    displacement : ndarray, shape (record, grid..., polarity)
        Each record's displacement as compared with the thresholds (``quantity``: the
        ``measure``), m.
    polarities, mode, yields
        The polarities run, the sliding mode and every yield (g; those not on an axis too).
    """

    _axes = RECORD_AXES
    _file_attr = "crandall_record_fragility"
    _intervals = "95 % intervals: Clopper-Pearson on n_eff"

    records: List[str] = field(default_factory=list)
    record_pga: Optional[np.ndarray] = None
    weights: Optional[np.ndarray] = None
    displacement: Optional[np.ndarray] = None
    polarities: Tuple[str, ...] = ("normal", "inverse")
    mode: str = "one-way"
    yields: Dict[str, List[float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        super().__post_init__()
        n = len(self.records)
        self.weights = np.ones(n) if self.weights is None else np.asarray(self.weights, float)
        self.record_pga = (np.full(n, np.nan) if self.record_pga is None
                           else np.asarray(self.record_pga, float))
        self.polarities = tuple(self.polarities)
        if self.displacement is not None:
            self.displacement = np.asarray(self.displacement, dtype=float)
            want = (n,) + self.run.shape + (len(self.polarities),)
            if self.displacement.shape != want:
                raise ParameterError("displacement", f"displacement: shape {self.displacement.shape}, expected {want}")

    @property
    def n_eff(self) -> float:
        return effective_size(self.weights)

    def _section_extra(self, j: int) -> Dict[str, Any]:
        return {} if self.displacement is None else {"displacement": self.displacement[:, :, j]}

    def _header(self) -> str:
        over = self.axis + ("" if self.by is None else f" and {self.by}")
        return (f"P({self.quantity} > threshold [m]) over {over}: the weighted fraction of "
                f"{len(self.records)} records (n_eff {self.n_eff:.3g}), "
                f"{'/'.join(self.polarities)} polarity, {self.mode}, {self.method}")

    # -- the lognormal fit: binomial maximum likelihood ------------------------------------

    def _fit(self) -> LognormalFit:
        """Per threshold, P(x) = Phi(s (ln x - ln median) / beta) by maximum likelihood of
        the fractions as binomial with n_eff trials (the likelihood of Baker's multiple-stripe
        fit, n_eff p_i exceedances of n_eff at each grid point; the same records at every
        point, so the points are not independent and the intervals are indicative):

            ln L = n_eff sum_i [p_i ln Phi(z_i) + (1 - p_i) ln Phi(-z_i)],  z_i = s (ln x_i - ln median) / beta.

        Covariance: the inverse Fisher information, times chi2 / dof when above 1 (chi2 the
        Pearson statistic n_eff sum (p_i - P_i)^2 / (P_i (1 - P_i)), as the tail fit widens).
        A threshold gets a fit (else NaN) with at least two grid points strictly between 0
        and 1: with fewer, a step (beta -> 0) fits best."""
        from scipy.optimize import minimize
        from scipy.special import log_ndtr, ndtr, ndtri

        sign = _SIGN[self.axis]
        lx = np.log(self.values)
        n = self.n_eff
        nt = len(self.thresholds)
        out = {k: np.full(nt, np.nan) for k in ("median", "median_stderr", "median_low",
                                               "median_high", "beta", "beta_stderr", "beta_low",
                                               "beta_high", "chi2")}
        cov_all = np.full((nt, 2, 2), np.nan)
        dof = np.zeros(nt, dtype=np.int64)
        points = np.zeros(nt, dtype=np.int64)
        for k in range(nt):
            p = self.probability[:, k]
            points[k] = len(p)
            if int(((p > 0) & (p < 1)).sum()) < 2:
                continue

            def nll(theta):
                z = sign * (lx - theta[0]) / math.exp(theta[1])
                return -n * float(np.sum(p * log_ndtr(z) + (1 - p) * log_ndtr(-z)))

            # Start: the probit line through the fractions kept inside (0, 1).
            zq = ndtri(np.clip(p, 0.5 / max(n, 1.0), 1 - 0.5 / max(n, 1.0)))
            slope, icept = np.polyfit(lx, zq, 1)
            slope = sign * slope
            start = ([float(sign * -icept / slope) if sign > 0 else float(icept / slope),
                      -math.log(slope)] if np.isfinite(slope) and slope > 0
                     else [float(np.mean(lx)), 0.0])
            fit = minimize(nll, start, method="Nelder-Mead",
                           options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000})
            a, b = float(fit.x[0]), math.exp(float(fit.x[1]))
            if not (fit.success and np.isfinite(a) and np.isfinite(b) and b > 1e-6):
                continue
            z = sign * (lx - a) / b
            big = ndtr(z)
            dens = np.exp(-0.5 * z * z) / math.sqrt(2 * math.pi)
            grad = np.stack([np.full_like(z, -sign / b), -z / b], axis=1)   # dz/d(ln median, beta)
            weight = n * dens ** 2 / np.maximum(big * (1 - big), 1e-300)
            info = (grad * weight[:, None]).T @ grad
            try:
                cov = np.linalg.inv(info)
            except np.linalg.LinAlgError:
                cov = np.full((2, 2), np.inf)
            chi2 = float(n * np.sum((p - big) ** 2 / np.maximum(big * (1 - big), 1e-300)))
            dof[k] = len(p) - 2
            if dof[k] > 0:
                cov = cov * max(1.0, chi2 / dof[k])
            sa, sb = math.sqrt(max(cov[0, 0], 0.0)), math.sqrt(max(cov[1, 1], 0.0))
            out["median"][k] = math.exp(a)
            out["median_stderr"][k] = math.exp(a) * sa
            out["median_low"][k], out["median_high"][k] = (math.exp(a - _Z95 * sa),
                                                           math.exp(a + _Z95 * sa))
            out["beta"][k], out["beta_stderr"][k] = b, sb
            out["beta_low"][k], out["beta_high"][k] = max(b - _Z95 * sb, 0.0), b + _Z95 * sb
            out["chi2"][k] = chi2
            cov_all[k] = cov
        return LognormalFit(thresholds=self.thresholds.copy(), covariance=cov_all, dof=dof,
                            points=points, sign=sign, **out)

    # -- files -----------------------------------------------------------------------------

    def to_xarray(self):
        """FragilityResult's Dataset, and the records' names, PGA and weights over "record",
        the displacements over (record, grid..., polarity), the mode and yields (JSON)."""
        import json

        ds = super().to_xarray()
        ds = ds.assign_coords(record=list(self.records), polarity=list(self.polarities))
        ds["record_pga"] = ("record", self.record_pga)
        ds["weight"] = ("record", self.weights)
        if self.displacement is not None:
            grid = (self.axis,) if self.by is None else (self.axis, self.by)
            ds["displacement"] = (("record",) + grid + ("polarity",), self.displacement)
        ds.attrs.update(sliding=self.mode, yields=json.dumps(self.yields))
        return ds

    @classmethod
    def _from_dataset(cls, ds) -> Dict[str, Any]:
        import json

        out = super()._from_dataset(ds)
        out.update(records=[str(x) for x in ds["record"].values],
                   record_pga=ds["record_pga"].values, weights=ds["weight"].values,
                   displacement=ds["displacement"].values if "displacement" in ds else None,
                   polarities=tuple(str(x) for x in ds["polarity"].values),
                   mode=str(ds.attrs["sliding"]), yields=json.loads(str(ds.attrs["yields"])))
        return out

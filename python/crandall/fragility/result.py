"""A fragility result (:class:`FragilityResult`): its table, lognormal fit, hazard integral,
summary and file, and :func:`load`, which reads a saved one back."""

from __future__ import annotations

import html
import json
import math
import os
import warnings
from dataclasses import dataclass, field, replace
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from .._files import write_atomic
from ..errors import ParameterError
from ..results import StatisticsWarning
from .grid import AXES, _LABEL, _SHORT, _SIGN, _Z95
from .hazard import Hazard, LognormalFit, _hazard_curve, _sub_grid


@dataclass
class FragilityResult:
    """P(quantity > threshold) over a grid of intensities or frictions, or both.

    Attributes
    ----------
    quantity, axis, values, thresholds, units
        The quantity; the grid's axis ("intensity": h in m s^-3/2, or "mu") and its values;
        the thresholds and their unit.
    by, by_values
        A grid over two axes: the second one ("mu") and its values, a curve over ``axis`` for
        each (None for a grid over one axis). :meth:`section` gives the curve of one.
    probability, stderr, low, high : ndarray, shape (len(values), [len(by_values),] len(thresholds))
        The tail estimates, their standard errors and 95 % intervals (crandall.tail's).
    reliable : ndarray of bool
        crandall.tail's flag (False: not a clean estimate; left out of the fit).
    run : ndarray of int, shape (len(values), [len(by_values)])
        The tail run each grid point came from (points of one run share it: the scaling
        identity, :data:`crandall.model.SCALING`); ``runs`` counts the distinct ones.
    shared : bool
        Whether any run served several points.
    seed, scene, seconds, steps, method
        The fragility's seed, the user's scene (plain data), the runs' total wall time and
        exact steps, the tail method.
    """

    #: The axes a result of this class may have (crandall.suites' records have theirs).
    _axes = AXES
    #: The netCDF attribute that marks a saved result of this class.
    _file_attr = "crandall_fragility"
    #: What the tables say of the intervals.
    _intervals = "95 % intervals (the tail's)"

    quantity: str
    axis: str
    values: np.ndarray
    thresholds: np.ndarray
    probability: np.ndarray
    stderr: np.ndarray
    low: np.ndarray
    high: np.ndarray
    reliable: np.ndarray
    units: str = ""
    run: Optional[np.ndarray] = None
    shared: bool = False
    seed: Optional[int] = None
    scene: Dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    steps: int = 0
    method: str = "splitting"
    rel_error_target: float = 0.1
    by: Optional[str] = None
    by_values: Optional[np.ndarray] = None

    def __post_init__(self) -> None:
        self.values = np.asarray(self.values, dtype=float)
        self.thresholds = np.asarray(self.thresholds, dtype=float)
        for name in ("probability", "stderr", "low", "high"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=float))
        self.reliable = np.asarray(self.reliable, dtype=bool)
        if self.axis not in self._axes:
            raise ParameterError("axis", f"axis must be one of {', '.join(self._axes)}, got "
                                         f"{self.axis!r}")
        if (self.by is None) != (self.by_values is None):
            raise ParameterError("by, by_values", "by, by_values: give both (a grid over two "
                                                  "axes) or neither")
        grid: Tuple[int, ...] = (len(self.values),)
        if self.by is not None:
            if self.by not in self._axes or self.by == self.axis:
                raise ParameterError("by", f"by must be one of {', '.join(self._axes)} other than "
                                           f"the axis, got {self.by!r}")
            self.by_values = np.asarray(self.by_values, dtype=float)
            grid += (len(self.by_values),)
        if self.run is None:
            self.run = np.arange(int(np.prod(grid))).reshape(grid)
        self.run = np.asarray(self.run, dtype=np.int64)
        if self.run.shape != grid:
            raise ParameterError("run", f"run: shape {self.run.shape}, expected {grid}")
        shape = grid + (len(self.thresholds),)
        for name in ("probability", "stderr", "low", "high", "reliable"):
            if getattr(self, name).shape != shape:
                raise ParameterError(name, f"{name}: shape {getattr(self, name).shape}, expected "
                                           f"{shape}")

    @property
    def axis_label(self) -> str:
        return _LABEL[self.axis]

    @property
    def runs(self) -> int:
        """How many distinct runs (tail runs; for records, newmark sweeps) made the grid."""
        return int(np.unique(self.run).size)

    def sections(self) -> List["FragilityResult"]:
        """The curves over ``axis``, one per value of ``by`` (``[self]`` for one axis)."""
        if self.by is None:
            return [self]
        return [self.section(j) for j in range(len(self.by_values))]

    def section(self, j: int) -> "FragilityResult":
        """The curve over ``axis`` at ``by_values[j]`` of a grid over two axes: a one-axis
        result of the same class, its scene's ``by`` set to that value (``shared`` and
        ``seconds`` remain the whole grid's)."""
        if self.by is None:
            raise ValueError("section: this result is over one axis")
        if not (isinstance(j, (int, np.integer)) and -len(self.by_values) <= j < len(self.by_values)):
            raise ParameterError("j", f"j must be an index into by_values "
                                      f"(0 ... {len(self.by_values) - 1}), got {j!r}")
        scene = dict(self.scene)
        if scene and self.by in scene:
            scene[self.by] = float(self.by_values[j])
        sliced = {name: getattr(self, name)[:, j] for name in
                  ("probability", "stderr", "low", "high", "reliable", "run")}
        return replace(self, by=None, by_values=None, scene=scene,
                       **sliced, **self._section_extra(int(j)))

    def _section_extra(self, j: int) -> Dict[str, Any]:
        """The fields a subclass slices for :meth:`section` (none here)."""
        return {}

    @property
    def _by_label(self) -> str:
        return "" if self.by is None else _SHORT[self.by]

    # -- the lognormal fit -----------------------------------------------------------------

    def fit_lognormal(self) -> Union[LognormalFit, List[LognormalFit]]:
        """The lognormal fragility curve of each threshold by maximum likelihood: a
        :class:`LognormalFit`; over two axes, a list of them, the curve over ``axis`` for each
        value of ``by`` (``[s.fit_lognormal() for s in self.sections()]``).

        Model: P(x) = Phi(s (ln x - ln median) / beta), s = +1 over intensities, -1 over mu.

        Likelihood: at grid point i the tail's estimate p_i is the mean of many independent
        replicas (or weighted paths), so it is close to normal with the reported standard
        error se_i; its logarithm, by the delta method, close to normal with standard
        deviation se_i / p_i (the relative error, about the run's target at every point). The
        fit maximises

            L = prod_i exp(-(ln Phi(s (ln x_i - ln median) / beta) - ln p_i)^2 / (2 (se_i / p_i)^2)),

        a weighted least squares on ln p. The logarithm, not p itself: p spans decades and a
        relative error is what a tail run controls, so a misfit by a factor 10 weighs the
        same at 1e-9 and at 1e-2, where on p it would weigh 1e7 times less at 1e-9. Points
        left out: p = 0, se = 0 (no noise to weigh), and those the tail did not flag reliable.

        Uncertainty: the inverse of the Gauss-Newton information J^T J at the optimum (J the
        Jacobian of the weighted residuals in (ln median, beta)), multiplied by chi2 / dof
        when that exceeds 1 (the Birge ratio: a curve that is not quite lognormal, which the
        estimates' own errors would not explain, widens the parameters' errors instead of
        hiding behind them). The 95 % intervals: exp(ln median +- 1.96 se) and
        beta +- 1.96 se (clipped at 0).
        """
        if self.by is not None:
            return [s.fit_lognormal() for s in self.sections()]
        return self._fit()

    def _fit(self) -> LognormalFit:
        from scipy.optimize import least_squares
        from scipy.special import log_ndtr, ndtri

        sign = _SIGN[self.axis]
        lx = np.log(self.values)
        n = len(self.thresholds)
        out = {k: np.full(n, np.nan) for k in ("median", "median_stderr", "median_low",
                                              "median_high", "beta", "beta_stderr", "beta_low",
                                              "beta_high", "chi2")}
        cov_all = np.full((n, 2, 2), np.nan)
        dof = np.zeros(n, dtype=np.int64)
        points = np.zeros(n, dtype=np.int64)
        for k in range(n):
            p, se = self.probability[:, k], self.stderr[:, k]
            use = self.reliable[:, k] & (p > 0) & (se > 0) & np.isfinite(p) & np.isfinite(se)
            points[k] = int(use.sum())
            if points[k] < 2:
                continue
            x, lp, sd = lx[use], np.log(p[use]), se[use] / p[use]

            def residuals(theta):
                return (log_ndtr(sign * (x - theta[0]) / theta[1]) - lp) / sd

            # Start: the probit line, Phi^-1(p) = s (ln x - ln median) / beta.
            zq = ndtri(np.clip(p[use], 1e-300, 1 - 1e-12))
            slope, icept = np.polyfit(x, zq, 1) if len(x) > 1 else (1.0, 0.0)
            slope = sign * slope
            if not (np.isfinite(slope) and slope > 0):
                start = [float(np.mean(x)), 1.0]
            else:
                start = [float(sign * -icept / slope) if sign > 0 else float(icept / slope),
                         1.0 / slope]
            fit = least_squares(residuals, start, bounds=([-np.inf, 1e-9], [np.inf, np.inf]),
                                method="trf", x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14)
            jac = fit.jac
            chi2 = float(np.sum(fit.fun ** 2))
            dof[k] = len(x) - 2
            try:
                cov = np.linalg.inv(jac.T @ jac)
            except np.linalg.LinAlgError:
                cov = np.full((2, 2), np.inf)
            if dof[k] > 0:
                cov = cov * max(1.0, chi2 / dof[k])
            a, b = fit.x
            sa, sb = math.sqrt(max(cov[0, 0], 0.0)), math.sqrt(max(cov[1, 1], 0.0))
            if not (np.isfinite(a) and abs(a) + _Z95 * sa < 700.0):
                # No lognormal curve rising along the axis fits (the estimates fall where it
                # should rise, or stay flat): the median runs off beyond doubles. NaN, said.
                warnings.warn(f"fit_lognormal: no lognormal curve fits the estimates at "
                              f"threshold {self.thresholds[k]:g} (its median runs off to "
                              f"exp({a:.3g})): left NaN", StatisticsWarning, stacklevel=3)
                continue
            out["median"][k] = math.exp(a)
            out["median_stderr"][k] = math.exp(a) * sa
            out["median_low"][k], out["median_high"][k] = math.exp(a - _Z95 * sa), math.exp(a + _Z95 * sa)
            out["beta"][k], out["beta_stderr"][k] = b, sb
            out["beta_low"][k], out["beta_high"][k] = max(b - _Z95 * sb, 0.0), b + _Z95 * sb
            out["chi2"][k] = chi2
            cov_all[k] = cov
        return LognormalFit(thresholds=self.thresholds.copy(), covariance=cov_all, dof=dof,
                            points=points, sign=sign, **out)

    # -- the hazard ------------------------------------------------------------------------

    def hazard(self, curve, fit: Optional[LognormalFit] = None,
               use: str = "fit") -> Union[Hazard, List[Hazard]]:
        """The annual rate of exceeding each threshold at a site whose hazard curve is
        ``curve = (im, rate)``: ``rate[i]`` the annual rate of shaking stronger than
        ``im[i]`` (the intensity of this result's grid: h in m s^-3/2, or a record suite's
        PGA in g; increasing, the rates non-increasing). A :class:`Hazard`; over two axes a
        list of them, one per value of ``by`` (``fit``, if given, a list of fits as
        :meth:`fit_lognormal` returns).

            lambda_D(d) = int P(D > d | x) |d lambda(x)|

        lambda interpolated linearly in (ln x, ln lambda) between the curve's points (exact
        for a power law), on a sub-grid of steps of at most 0.002 in ln x (the trapezoid rule
        on P against the falls of lambda). Two ways of taking P:

        ``use="fit"`` (default): the fitted lognormal curve (:meth:`fit_lognormal`, or
        ``fit``), over the hazard curve's range; shaking beyond its last point counts with P
        at that point, shaking below its first not at all. Uncertainty: the fit's
        covariance of (ln median, beta) by the delta method (central differences). Where
        the curve is not lognormal (chi2 / dof well above 1) this is the fitted curve's rate.

        ``use="estimates"``: the grid's own estimates, ln P interpolated linearly in ln x
        between grid points (reliable, P > 0), over the part of the hazard curve inside the
        grid; shaking above that part counts with P at its upper end, shaking below it not
        at all (both lower bounds, with P growing with h: ``Hazard.outside`` is the most
        they could add, (1 - P(b)) lambda(b) + P(a) (lambda(im[0]) - lambda(a)) for the part
        [a, b]). Uncertainty: each estimate's standard error, through the integral's
        derivative in it (central differences), added linearly within one tail run (the
        estimates of one run are correlated, by an unknown amount: the sum is the bound)
        and in quadrature across runs (independent).

        The 95 % interval is rate * exp(+-1.96 stderr / rate).
        """
        if _SIGN[self.axis] < 0:
            raise ParameterError("curve", f"curve: a hazard curve is one of the intensity; this "
                                          f"fragility is over {self.axis}")
        if use not in ("fit", "estimates"):
            raise ParameterError("use", f"use must be 'fit' or 'estimates', got {use!r}")
        if self.by is not None:
            fits = [None] * len(self.by_values) if fit is None else list(fit)
            if len(fits) != len(self.by_values):
                raise ParameterError("fit", f"fit: one per value of {self.by} "
                                            f"({len(self.by_values)}), got {len(fits)}")
            return [s.hazard(curve, fit=f, use=use) for s, f in zip(self.sections(), fits)]
        im, rate = _hazard_curve(curve)
        lx, lr = np.log(im), np.log(rate)
        n = len(self.thresholds)
        out, err = np.full(n, np.nan), np.full(n, np.nan)
        outside = np.zeros(n)
        if use == "fit":
            fit = self.fit_lognormal() if fit is None else fit
            from scipy.special import ndtr

            sub_x, lam = _sub_grid(lx, lr, lx[0], lx[-1])
            drop = lam[:-1] - lam[1:]

            def integral(lnmed, beta):
                p = ndtr(fit.sign * (sub_x - lnmed) / beta)
                return float(np.sum(0.5 * (p[:-1] + p[1:]) * drop) + p[-1] * lam[-1])

            for k in range(n):
                if not np.isfinite(fit.median[k]):
                    continue
                a, b = math.log(fit.median[k]), fit.beta[k]
                out[k] = integral(a, b)
                ha, hb = 1e-6 * max(1.0, abs(a)), 1e-6 * b
                grad = np.array([(integral(a + ha, b) - integral(a - ha, b)) / (2 * ha),
                                 (integral(a, b + hb) - integral(a, b - hb)) / (2 * hb)])
                err[k] = math.sqrt(max(float(grad @ fit.covariance[k] @ grad), 0.0))
        else:
            gx = np.log(self.values)
            for k in range(n):
                p, se = self.probability[:, k], self.stderr[:, k]
                use_k = self.reliable[:, k] & (p > 0) & np.isfinite(p) & np.isfinite(se)
                if use_k.sum() < 2:
                    continue
                px, lp, sk, runs = gx[use_k], np.log(p[use_k]), se[use_k], self.run[use_k]
                lo_x, hi_x = max(px[0], lx[0]), min(px[-1], lx[-1])
                if not hi_x > lo_x:
                    continue
                sub_x, lam = _sub_grid(lx, lr, lo_x, hi_x, extra=px)
                drop = lam[:-1] - lam[1:]

                def integral(logp):
                    q = np.exp(np.interp(sub_x, px, logp))
                    return float(np.sum(0.5 * (q[:-1] + q[1:]) * drop) + q[-1] * lam[-1])

                out[k] = integral(lp)
                grad = np.zeros(len(lp))
                for i in range(len(lp)):
                    h = 1e-6
                    up, down = lp.copy(), lp.copy()
                    up[i] += h
                    down[i] -= h
                    # d/dP_i = d/d(ln P_i) / P_i
                    grad[i] = (integral(up) - integral(down)) / (2 * h) / math.exp(lp[i])
                var = 0.0
                for r in np.unique(runs):
                    var += float(np.sum(np.abs(grad[runs == r]) * sk[runs == r])) ** 2
                err[k] = math.sqrt(var)
                p_lo = math.exp(np.interp(lo_x, px, lp))
                p_hi = math.exp(np.interp(hi_x, px, lp))
                lam_lo = math.exp(np.interp(lo_x, lx, lr))
                outside[k] = (max(1.0 - p_hi, 0.0) * lam[-1]
                              + p_lo * (rate[0] - lam_lo))
        with np.errstate(divide="ignore", invalid="ignore"):
            spread = np.exp(_Z95 * err / out)
        return Hazard(self.thresholds.copy(), out, err, out / spread, out * spread, outside, use)

    # -- tables, files ---------------------------------------------------------------------

    def _header(self) -> str:
        """The table's first line (what made the estimates)."""
        unit = f" [{self.units}]" if self.units else ""
        over = _SHORT[self.axis] + ("" if self.by is None else f" and {self._by_label}")
        return (f"P({self.quantity} > threshold{unit}) over {over}, {self.method}, "
                f"{self.runs} tail runs for {self.run.size} points, {self.seconds:.1f} s")

    def __str__(self) -> str:
        name = _SHORT[self.axis]
        by = "" if self.by is None else f"{self._by_label:>10} "
        lines = [f"{self._header()}; {self._intervals}",
                 f"{name:>10} {by}{'threshold':>12} {'probability':>12} {'rel.err':>8} "
                 f"{'95% interval':>23}"]
        for i in np.ndindex(self.run.shape):
            x = f"{self.values[i[0]]:10.4g} " + ("" if self.by is None
                                                 else f"{self.by_values[i[1]]:10.4g} ")
            for k, d in enumerate(self.thresholds):
                p, s = self.probability[i + (k,)], self.stderr[i + (k,)]
                rel = s / p if p > 0 else math.inf
                flag = "" if self.reliable[i + (k,)] else "  UNRELIABLE"
                lines.append(f"{x}{d:12.6g} {p:12.4g} {rel:8.3f} "
                             f"[{self.low[i + (k,)]:9.3g}, {self.high[i + (k,)]:9.3g}]{flag}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        """The table as HTML: one row per grid value, a column per threshold (estimate and its
        95 % interval); over two axes a table per value of ``by``."""
        name = html.escape(_SHORT[self.axis])
        unit = f" [{html.escape(self.units)}]" if self.units else ""
        head = "".join(f"<th>&gt; {d:.4g}{unit}</th>" for d in self.thresholds)
        tables = []
        for j, sec in enumerate(self.sections()):
            rows = []
            for i, x in enumerate(sec.values):
                cells = []
                for k in range(len(sec.thresholds)):
                    flag = "" if sec.reliable[i, k] else " <b>unreliable</b>"
                    cells.append(f"<td>{sec.probability[i, k]:.4g}<br><small>"
                                 f"[{sec.low[i, k]:.3g}, {sec.high[i, k]:.3g}]</small>{flag}</td>")
                rows.append(f"<tr><th>{x:.4g}</th>{''.join(cells)}</tr>")
            caption = ("" if self.by is None else
                       f"<caption>{html.escape(self._by_label)} = {self.by_values[j]:.4g}</caption>")
            tables.append(f"<table>{caption}<tr><th>{name}</th>{head}</tr>{''.join(rows)}</table>")
        return (f"<div><p>{html.escape(self._header())}; {html.escape(self._intervals)}</p>"
                f"{''.join(tables)}</div>")

    def to_xarray(self):
        """An xarray Dataset over (``axis``, [``by``,] threshold): probability, stderr, low,
        high, reliable, run; the quantity, seed, scene (JSON) and the rest as attributes."""
        import xarray as xr

        grid = (self.axis,) if self.by is None else (self.axis, self.by)
        dims = grid + ("threshold",)
        coords = {self.axis: self.values, "threshold": self.thresholds}
        if self.by is not None:
            coords[self.by] = self.by_values
        ds = xr.Dataset(
            {name: (dims, getattr(self, name)) for name in ("probability", "stderr", "low", "high")},
            coords=coords)
        ds["reliable"] = (dims, self.reliable.astype(np.int8))
        ds["run"] = (grid, self.run)
        ds.attrs.update({self._file_attr: 1}, quantity=self.quantity, axis=self.axis,
                        by=self.by or "", units=self.units, shared=int(self.shared),
                        seed=str(self.seed) if self.seed is not None else "",
                        scene=json.dumps(self.scene), seconds=self.seconds, steps=self.steps,
                        method=self.method, rel_error_target=self.rel_error_target)
        return ds

    @classmethod
    def _from_dataset(cls, ds) -> Dict[str, Any]:
        """The fields of a result read from its Dataset (a subclass adds its own)."""
        a = ds.attrs
        axis = str(a["axis"])
        by = str(a.get("by", "")) or None
        return dict(
            quantity=str(a["quantity"]), axis=axis, values=ds[axis].values,
            by=by, by_values=None if by is None else ds[by].values,
            thresholds=ds["threshold"].values, probability=ds["probability"].values,
            stderr=ds["stderr"].values, low=ds["low"].values, high=ds["high"].values,
            reliable=ds["reliable"].values.astype(bool), units=str(a["units"]),
            run=ds["run"].values, shared=bool(int(a["shared"])),
            seed=int(a["seed"]) if str(a["seed"]) else None, scene=json.loads(str(a["scene"])),
            seconds=float(a["seconds"]), steps=int(a["steps"]), method=str(a["method"]),
            rel_error_target=float(a["rel_error_target"]))

    @classmethod
    def load(cls, path: Union[str, "os.PathLike[str]"]) -> "FragilityResult":
        """Read a file written by :meth:`save` (of this class or a subclass: the file says
        which)."""
        return load(path)

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Write a netCDF file (netCDF-3 by SciPy, as crandall's results), replaced
        atomically; :func:`load` reads it back."""
        ds = self.to_xarray()
        encoding = {name: {"_FillValue": None} for name in ds.coords}
        data = bytes(ds.to_netcdf(engine="scipy", format="NETCDF3_64BIT", encoding=encoding))
        write_atomic(path, lambda f: f.write(data))


def _kinds() -> Dict[str, type]:
    """Each class of saved fragility by its netCDF attribute (FragilityResult and its
    subclasses, e.g. crandall.suites.RecordFragilityResult)."""
    out, todo = {}, [FragilityResult]
    while todo:
        cls = todo.pop()
        out[cls._file_attr] = cls
        todo.extend(cls.__subclasses__())
    return out


def load(path: Union[str, "os.PathLike[str]"]) -> FragilityResult:
    """Read a file written by :meth:`FragilityResult.save` (or a subclass's: the result is of
    the class that wrote it)."""
    import xarray as xr

    with xr.open_dataset(os.fspath(path), engine="scipy") as ds:
        ds.load()
        for attr, cls in _kinds().items():
            if attr in ds.attrs:
                return cls(**cls._from_dataset(ds))
        raise ValueError(f"path: {os.fspath(path)} is not a saved crandall fragility")

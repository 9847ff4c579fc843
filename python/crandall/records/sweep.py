""":func:`newmark`: Newmark's sliding block on one record or a sweep over records, yields and
polarities, in the compiled core; the mode (one-way, two-way flat, two-way incline) its
yields name."""

from __future__ import annotations

from typing import Any, List, Optional, Tuple

import numpy as np

from .. import _core
from ..errors import ParameterError
from .record import G, METHODS, POLARITIES, Record, _SIGNS, _positive
from .result import NewmarkResult, SWEEP_SAMPLES


def _yield_values(name: str, value: Any, *, allow_inf: bool = False) -> np.ndarray:
    """A yield (in g) as a 1-D array of checked values."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return np.array([_positive(name, value, allow_inf=allow_inf)])
    if isinstance(value, (str, bytes)):
        raise ParameterError(name, f"{name} must be a number or a sequence of numbers")
    arr = np.asarray(value, dtype=object)
    if arr.ndim > 1 or arr.size == 0:
        raise ParameterError(name, f"{name} must be a number or a non-empty 1-D sequence")
    return np.array([_positive(name, v, allow_inf=allow_inf) for v in arr.reshape(-1)])


def _mode(ky, mu, mu_static, kd, ku):
    """The sliding mode and its yields (in g) per case: (mode, {name: array}, rows in g)."""
    given = [n for n, v in (("ky", ky), ("mu", mu), ("kd", kd), ("ku", ku)) if v is not None]
    if not given:
        raise ParameterError("ky", "ky: missing (give ky for one-way sliding, mu for two-way "
                                   "on a flat surface, or kd and ku for an incline)")
    if ky is not None and len(given) > 1 or mu is not None and len(given) > 1:
        raise ParameterError(", ".join(given), f"{', '.join(given)}: give ky, mu or (kd, ku), "
                                               "one of them")
    if mu_static is not None and mu is None:
        raise ParameterError("mu_static", "mu_static goes with mu (two-way on a flat surface)")
    if ky is not None:
        k = _yield_values("ky", ky)
        rows = np.full((k.size, 4), np.inf)
        rows[:, 0] = rows[:, 2] = k
        return "one-way", {"ky": k}, rows, np.ndim(ky) == 0
    if mu is not None:
        m = _yield_values("mu", mu)
        ms = m if mu_static is None else _yield_values("mu_static", mu_static)
        try:
            m, ms = np.broadcast_arrays(m, ms)
        except ValueError:
            raise ParameterError("mu, mu_static", "mu, mu_static: lengths differ") from None
        if np.any(ms < m):
            i = int(np.flatnonzero(ms < m)[0])
            raise ParameterError("mu_static", f"mu_static must be >= mu, got {ms[i]!r} < {m[i]!r}")
        scalar = np.ndim(mu) == 0 and (mu_static is None or np.ndim(mu_static) == 0)
        return ("flat", {"mu": m.copy(), "mu_static": ms.copy()},
                np.stack([m, m, ms, ms], axis=1), scalar)
    if kd is None or ku is None:
        missing = "kd" if kd is None else "ku"
        raise ParameterError(missing, f"{missing}: missing (an incline needs both kd and ku)")
    d = _yield_values("kd", kd)
    u = _yield_values("ku", ku, allow_inf=True)
    try:
        d, u = np.broadcast_arrays(d, u)
    except ValueError:
        raise ParameterError("kd, ku", "kd, ku: lengths differ") from None
    return ("incline", {"kd": d.copy(), "ku": u.copy()}, np.stack([d, u, d, u], axis=1),
            np.ndim(kd) == 0 and np.ndim(ku) == 0)


def _records(record, dt, units) -> Tuple[List[Record], bool]:
    if isinstance(record, Record):
        if dt is not None:
            raise ParameterError("dt", "dt: the record has its own (give dt with a plain array)")
        return [record], True
    if isinstance(record, (list, tuple)) and record and all(isinstance(r, Record) for r in record):
        if dt is not None:
            raise ParameterError("dt", "dt: the records have their own")
        return list(record), False
    if dt is None:
        raise ParameterError("dt", "dt: missing (a plain array of samples needs dt=, or give "
                                   "a crandall.Record)")
    return [Record(record, dt, units=units, name="record")], True


def newmark(record: Any, *, ky: Any = None, mu: Any = None, mu_static: Any = None,
            kd: Any = None, ku: Any = None, method: str = "exact", polarity: str = "normal",
            dt: Optional[float] = None, units: str = "g",
            threads: Optional[int] = None) -> "NewmarkResult":
    """Newmark's rigid sliding block on a recorded ground motion.

    Parameters
    ----------
    record : Record, list of Record, or sequence of float
        The ground acceleration; a plain sequence needs ``dt`` (and ``units``, default g).
    ky : float or sequence, optional
        One-way downslope sliding (SLAMMER's rigid block): the yield acceleration, in g. The
        sliding velocity W (ground minus block, positive downslope) obeys dW/dt = a - ky g
        while W > 0, and the block starts when a exceeds ky g.
    mu, mu_static : float or sequence, optional
        Two-way sliding on a flat surface: the body's velocity relative to the foundation V
        obeys dV/dt = -a - mu g sign V; at rest it sticks while |a| <= mu_static g
        (default mu_static = mu; >= mu).
    kd, ku : float or sequence, optional
        Two-way sliding on an incline, yield accelerations (in g) downslope and upslope (from a
        slope angle theta and friction mu: kd = mu cos theta - sin theta, ku = mu cos theta +
        sin theta); ku may be ``math.inf`` (no upslope sliding: one-way).
    method : {"exact", "slammer"}
        "exact": the record joined by straight lines, integrated exactly; "slammer":
        pySLAMMER 0.2.2's recursion, bit for bit (one-way only).
    polarity : {"normal", "inverse", "both"}
        The record as given, negated, or both.
    dt, units
        For a plain sequence: its sampling interval (s) and units ("g", "m/s2", "cm/s2").
    threads : int, optional
        The core's threads for a sweep (default: every core; the numbers do not depend on it).

    Returns
    -------
    NewmarkResult
        Displacements in m, positive downslope for one-way and inclines; for a flat surface
        the body's displacement relative to the foundation, positive in the direction of the
        record's positive acceleration.

    Raises
    ------
    ParameterError
        Naming the parameter: a yield that is missing, not a number, <= 0, NaN or infinite
        (ku may be infinite); mu_static < mu; several modes at once; an unknown method or
        polarity; "slammer" with a two-way mode; a record with a sample that is not finite, dt
        not finite and > 0, dt given with a Record; bad threads.
    """
    if method not in METHODS:
        raise ParameterError("method", f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if polarity not in POLARITIES:
        raise ParameterError("polarity", f"polarity must be one of {', '.join(POLARITIES)}, "
                                         f"got {polarity!r}")
    if threads is None:
        nthreads = 0
    elif isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ParameterError("threads", f"threads must be an integer >= 1, got {threads!r}")
    else:
        nthreads = int(threads)
    mode, yields, rows_g, scalar_yield = _mode(ky, mu, mu_static, kd, ku)
    if method == "slammer" and mode != "one-way":
        raise ParameterError("method", "method: 'slammer' is pySLAMMER's one-way rigid block: "
                                       "give ky (mu, kd and ku need method='exact')")
    records, single_record = _records(record, dt, units)
    polarities = ("normal", "inverse") if polarity == "both" else (polarity,)
    signs = [_SIGNS[p] for p in polarities]
    accelerations = [r.si() for r in records]
    if method == "slammer":  # ky in g: the recursion multiplies by g itself, as pySLAMMER
        core_rows = np.zeros_like(rows_g)
        core_rows[:, 0] = rows_g[:, 0]
    else:
        core_rows = rows_g * G   # (inf stays inf: one-way)
    dims = tuple(d for d, many in (("record", not single_record), ("yield", not scalar_yield),
                                   ("polarity", polarity == "both")) if many)
    history = None
    if not dims:
        a, r, s = accelerations[0], core_rows[0].tolist(), signs[0]
        try:
            if method == "exact":
                out = _core.newmark_exact(a, records[0].dt, s, *r)
            else:
                out = _core.newmark_slammer(a, records[0].dt, s, float(r[0]))
        except ValueError as exc:
            raise ParameterError("record", f"record: {exc}") from None
        summary, velocity, displacement, events = out
        table = np.array(summary, dtype=float).reshape(1, 1, 1, 4)
        history = {"velocity": velocity, "displacement": displacement, "events": events}
    else:
        # In calls of at most SWEEP_SAMPLES samples (about 35 ms), so that Ctrl-C stops a
        # long sweep between two of them (each case is independent: the same numbers).
        per_yield = sum(len(a) for a in accelerations) * len(signs)
        per_call = max(1, SWEEP_SAMPLES // max(per_yield, 1))
        dts = [r.dt for r in records]
        try:
            table = np.concatenate(
                [_core.newmark_sweep(accelerations, dts, core_rows[i:i + per_call], signs,
                                     method, nthreads)
                 for i in range(0, len(core_rows), per_call)], axis=1)
        except ValueError as exc:
            raise ParameterError("record", f"record: {exc}") from None
    # Finite summaries bound the histories: the displacement lies between its extremes, and a
    # velocity that overflowed would have taken the displacement with it.
    if not np.isfinite(table).all():
        raise ParameterError("record", "record: the displacement overflows doubles (samples "
                                       "or yields far beyond a ground motion's)")
    if mode == "flat":  # the body relative to the foundation: -W
        table = np.stack([-table[..., 0], -table[..., 2], -table[..., 1], table[..., 3]], axis=-1)
        if history is not None:
            ev = history["events"].copy()
            ev[:, 2] = -ev[:, 2]
            history = {"velocity": -history["velocity"],
                       "displacement": -history["displacement"], "events": ev}
    return NewmarkResult(
        records=[{"name": r.name, "dt": r.dt, "npts": r.npts, "pga": r.pga, "scale": r.scale,
                  "units": r.units} for r in records],
        mode=mode, method=method, yields=yields, polarities=polarities, dims=dims,
        table=table,
        acceleration=None if history is None else (accelerations[0], signs[0]),
        history=history)

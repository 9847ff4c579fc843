"""``crandall suite RECORD ...``: a suite of recorded ground motions as a fragility curve (the
weighted fraction of records whose Newmark displacement exceeds each threshold, per yield value
and per PGA the records are scaled to), with its lognormal fit, and, beside a stochastic
model's saved fragility, both on one figure."""

from __future__ import annotations

import os

from .. import plots
from .._files import write_atomic
from ..errors import ParameterError
from ..fragility import load as load_fragility
from ..records import Record
from ..suites import record_fragility


def _one_or_list(values):
    return None if values is None else (values[0] if len(values) == 1 else values)


def suite_command(args) -> int:
    """Read the records, sweep them, print the fractions and the fit; write what was asked."""
    fmt = None
    if args.figure is not None:
        fmt = os.path.splitext(args.figure)[1].lstrip(".").lower()
        if fmt not in plots.FORMATS:
            raise ParameterError("--figure", f"--figure: the file must end in one of "
                                             f"{', '.join('.' + f for f in plots.FORMATS)}")
    if args.model is not None and args.figure is None:
        raise ParameterError("--model", "--model draws a stochastic fragility beside the "
                                        "records' on the figure: give --figure too")
    model = load_fragility(args.model) if args.model is not None else None  # fails early
    if args.weights is not None and len(args.weights) != len(args.records):
        raise ParameterError("--weights", f"--weights: {len(args.weights)} weights for "
                                          f"{len(args.records)} records")
    records = [Record.read(path, dt=args.dt, units=args.units) for path in args.records]
    result = record_fragility(records, args.thresholds, ky=_one_or_list(args.ky),
                              mu=_one_or_list(args.mu), mu_static=_one_or_list(args.mu_static),
                              kd=_one_or_list(args.kd), ku=_one_or_list(args.ku),
                              pga=args.pga, weights=args.weights, polarity=args.polarity,
                              measure=args.measure, method=args.method,
                              threads=args.threads if args.threads else None)
    print(result)
    if len(result.values) >= 2:
        fits = result.fit_lognormal()
        for j, fit in enumerate(fits if result.by else [fits]):
            at = "" if result.by is None else f" at {result.by} = {result.by_values[j]:.4g}"
            print(f"lognormal fit per threshold{at} (95 % intervals):")
            print(fit)
    else:
        print(f"(one value of {result.axis}: no curve to fit)")
    if args.save:
        result.save(args.save)
        print(f"wrote {args.save}")
    if args.figure:
        fig = (plots.fragility(model, records=result) if model is not None
               else plots.fragility(result))
        write_atomic(args.figure, lambda f: fig.savefig(f, format=fmt))
        print(f"wrote {args.figure}")
    return 0

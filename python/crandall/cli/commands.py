"""``crandall tail``, ``crandall fragility``, ``crandall scenes`` and ``crandall newmark``, and
:func:`main`, which parses the arguments and runs a subcommand."""

from __future__ import annotations

import math
import os
import sys
from typing import Optional, Sequence

import numpy as np

from .. import plots
from .._files import check_folder_writable, write_atomic
from ..records import Record, newmark
from ..scene import Scene
from ..simulate import simulate
from ..spec import draw_seed
from ..tail import TAIL_QUANTITIES, StatisticsFailure, tail
from ..errors import ParameterError
from ..fragility import fragility, hazard_csv, read_hazard_curve
from .outputs import DEFAULT_MC_PATHS, DEFAULT_TAIL_OUT, TAIL_MANIFEST, _TAIL_OUTPUTS, _check_out, _write_manifest
from .parser import _parser, resolve
from .simulation import _load_scene, _read_scene, analytic_command, note_unused_run_table, run
from .suite import suite_command


#: The quantities of ``crandall tail`` whose plain Monte Carlo part a fixed-step run gives
#: (a distribution at the stop), with the observables that run needs.
_TAIL_REFERENCE = {
    "stop_time": ["stop"], "distance_at_stop": ["distance", "stop"],
    "dissipated_energy_at_stop": ["dissipated_energy", "stop"],
    "displacement_at_stop": ["displacement", "stop"],
    "residual_displacement": ["displacement", "stop", "residual"],
}


def tail_command(scene_path: Optional[str] = None, *, quantity: str, levels, time=None,
                 method: str = "splitting", rel_error: float = 0.1, seed=None, dt=None,
                 threads=None, max_seconds: float = 3600.0, checkpoint=None,
                 mc_paths: Optional[int] = None, out: str = DEFAULT_TAIL_OUT,
                 overwrite: bool = False,
                 files: bool = True, progress=None, figure_format: str = "png",
                 dpi: int = 150) -> int:
    """``crandall tail``: the table at the given levels, tail.csv, tail.nc (the result:
    crandall.load reads it) and the curve (tail.png). ``mc_paths``: the plain Monte Carlo
    part of the curve (None: ``DEFAULT_MC_PATHS``), refused where the curve has none."""
    scene, settings, _ = _load_scene(scene_path)
    if quantity not in TAIL_QUANTITIES:
        raise ParameterError("--quantity", "--quantity must be one of "
                                           f"{', '.join(TAIL_QUANTITIES)}; got {quantity!r}")
    if mc_paths is None:
        mc_paths = DEFAULT_MC_PATHS
    elif quantity not in _TAIL_REFERENCE:
        raise ParameterError("--mc-paths", f"--mc-paths has no effect with --quantity {quantity} "
                                           "(its curve has no plain Monte Carlo part: that is "
                                           f"drawn for {', '.join(_TAIL_REFERENCE)})")
    earlier = _check_out(out, overwrite, _TAIL_OUTPUTS) if files else []
    if scene_path is not None:
        note_unused_run_table(scene_path, settings, "crandall tail")
    if seed is None:
        seed = draw_seed()
        print(f"seed: {seed}")
    levels = [float(x) for x in levels]
    curve_levels = list(levels)
    reference = None
    if files and quantity in _TAIL_REFERENCE:
        # Plain Monte Carlo on the same grid (method exact): the curve's upper part and where
        # the curve starts (its 10 % quantile: P about 0.9).
        ref_scene = Scene.from_dict({**scene.to_dict(), "observe": _TAIL_REFERENCE[quantity],
                                     "distributions": [quantity], "bins": None})
        reference = simulate(ref_scene, paths=mc_paths, seed=seed, dt=dt, method="exact",
                             threads=threads, progress=False)
        low = reference.quantile(quantity, 0.1).value
        if math.isfinite(low) and low < levels[-1]:
            curve_levels = sorted(set(levels) | set(np.linspace(low, levels[-1], 24).tolist()))
    result = tail(scene, quantity, curve_levels, time=time, method=method, rel_error=rel_error,
                  seed=seed, dt=dt, threads=threads, max_seconds=max_seconds,
                  checkpoint=checkpoint, progress=progress)
    pick = [curve_levels.index(x) for x in levels]
    lo, hi = result.interval()
    unit = f" [{result.units}]" if result.units else ""
    print(f"P({quantity} > level): {method}, {result.samples} "
          f"{'replicas' if method == 'splitting' else 'paths'}, {result.seconds:.1f} s")
    print(f"{'level' + unit:>16} {'probability':>12} {'stderr':>10} {'rel.err':>8}  95% interval")
    for i in pick:
        flag = "" if result.reliable[i] else "  UNRELIABLE (see the diagnostics)"
        print(f"{result.levels[i]:16.6g} {result.probability[i]:12.4g} {result.stderr[i]:10.3g} "
              f"{result.rel_error[i]:8.3f}  [{lo[i]:.3g}, {hi[i]:.3g}]{flag}")
    if not files:
        return 0
    check_folder_writable(out, "--out", create=True)
    for name in earlier:
        try:
            os.unlink(os.path.join(out, name))
        except FileNotFoundError:
            pass
    written = []
    failing = True
    try:
        rows = ["level,units,probability,stderr,rel_error,lower_95,upper_95,reliable\n"]
        rows += [",".join([repr(float(result.levels[i])), result.units,
                           *(repr(float(a[i])) for a in (result.probability, result.stderr,
                                                         result.rel_error, lo, hi)),
                           str(bool(result.reliable[i]))]) + "\n"
                 for i in range(len(result.levels))]
        path = os.path.join(out, "tail.csv")
        write_atomic(path, lambda f: f.write("".join(rows).encode()))
        written.append(path)
        try:
            import xarray  # noqa: F401  (the io extra: TailResult.save's netCDF)
        except ImportError as exc:
            print(f"crandall: note: tail.nc not written ({exc})", file=sys.stderr)
        else:
            path = os.path.join(out, "tail.nc")
            result.save(path)
            written.append(path)
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError as exc:
            print(f"crandall: note: figure not drawn ({exc})", file=sys.stderr)
        else:
            fig, ax = plt.subplots(figsize=(6.4, 4.4))
            result.plot(ax=ax, reference=reference)
            path = os.path.join(out, f"tail.{figure_format}")
            fig.tight_layout()
            try:
                write_atomic(path, lambda f: fig.savefig(f, dpi=dpi, format=figure_format))
            finally:
                plt.close(fig)
            written.append(path)
        failing = False
    finally:
        _write_manifest(out, written, failing, TAIL_MANIFEST)
    for p in written:
        print(f"wrote {p}")
    return 0


def fragility_command(args) -> int:
    """``crandall fragility``: the table over the grid and the lognormal fit per threshold."""
    scene = _read_scene(args.scene if args.scene is not None else "crate")
    seed = args.seed
    if seed is None:
        seed = draw_seed()
        print(f"seed: {seed}")
    if args.figure is not None:
        fmt = os.path.splitext(args.figure)[1].lstrip(".").lower()
        if fmt not in plots.FORMATS:
            raise ParameterError("--figure", f"--figure: the file must end in one of "
                                             f"{', '.join('.' + f for f in plots.FORMATS)}")
    curve = None
    if args.hazard is not None:
        if args.intensities is None:
            raise ParameterError("hazard", "--hazard: a hazard curve is one of the intensity; "
                                           "give --intensities")
        curve = read_hazard_curve(args.hazard)  # before the runs: a bad file fails at once
    elif args.hazard_save is not None:
        raise ParameterError("hazard_save", "--hazard-save needs --hazard FILE")
    if args.scene is not None:
        note_unused_run_table(args.scene, scene.run_settings, "crandall fragility")
    result = fragility(scene, args.quantity, args.thresholds, intensities=args.intensities,
                       mu=args.mu, rel_error=args.rel_error, seed=seed, threads=args.threads,
                       progress=args.progress, time=args.time, dt=args.dt, method=args.method,
                       max_seconds=args.max_seconds)
    print(result)
    fits = result.fit_lognormal()
    for j, fit in enumerate(fits if result.by else [fits]):
        at = "" if result.by is None else f" at {result.by} = {result.by_values[j]:.4g}"
        print(f"lognormal fit per threshold{at} (95 % intervals):")
        print(fit)
    if curve is not None:
        hazards = result.hazard(curve, fit=fits, use=args.hazard_use)
        hazards = hazards if result.by else [hazards]
        for j, hzd in enumerate(hazards):
            if result.by is not None:
                print(f"{result.by} = {result.by_values[j]:.4g}:")
            print(hzd)
        if args.hazard_save:
            text = hazard_csv(hazards, result.units, result.by, result.by_values)
            write_atomic(args.hazard_save, lambda f: f.write(text.encode()))
            print(f"wrote {args.hazard_save}")
    if args.save:
        result.save(args.save)
        print(f"wrote {args.save}")
    if args.figure:
        fig = plots.fragility(result, hazard=curve, use=args.hazard_use)
        write_atomic(args.figure, lambda f: fig.savefig(f, format=fmt))
        print(f"wrote {args.figure}")
    return 0


def scenes_command() -> int:
    """``crandall scenes``: the shipped scenes, a name and its title a line."""
    listed = Scene.shipped()
    width = max(map(len, listed), default=0)
    for name, title in listed.items():
        print(f"{name:<{width}}  {title}")
    return 0


def _one(values):
    return None if values is None else (values[0] if len(values) == 1 else values)


def newmark_command(args) -> int:
    """``crandall newmark RECORD ...``: the table of displacements, and the files asked for."""
    record = Record.read(args.record, dt=args.dt, units=args.units)
    if args.scale is not None:
        record = record.scaled(args.scale)
    elif args.pga is not None:
        record = record.scaled(pga=args.pga)
    result = newmark(record, ky=_one(args.ky), mu=_one(args.mu),
                     mu_static=_one(args.mu_static), kd=_one(args.kd), ku=_one(args.ku),
                     method=args.method, polarity=args.polarity,
                     threads=args.threads if args.threads else None)
    if args.figure is not None and result.dims:
        raise ParameterError("--figure", "--figure draws one case: give one yield value and one "
                                         "polarity")
    print(f"{record!r}")
    sense = ("relative to the foundation" if result.mode == "flat" else "positive downslope")
    print(f"{result.mode} block, method {result.method}; displacements in m, {sense}")
    names = list(result.yields)
    header = "  ".join(f"{n:>9}" for n in names)
    print(f"{header}  {'polarity':>8}  {'displacement':>13}  {'max':>11}  {'min':>11}  "
          f"{'slips':>5}")
    for k in range(result.table.shape[1]):
        for p, pol in enumerate(result.polarities):
            d, hi, lo, n = result.table[0, k, p]
            ys = "  ".join(f"{result.yields[n][k]:>9.4g}" for n in names)
            print(f"{ys}  {pol:>8}  {d:>13.6g}  {hi:>11.5g}  {lo:>11.5g}  {int(n):>5}")
    if args.save:
        result.save(args.save)
        print(f"wrote {args.save}")
    if args.figure:
        fmt = os.path.splitext(args.figure)[1].lstrip(".").lower()
        if fmt not in plots.FORMATS:
            raise ParameterError("--figure", f"--figure: the file must end in one of "
                                             f"{', '.join('.' + f for f in plots.FORMATS)}")
        fig = plots.newmark(result)
        write_atomic(args.figure, lambda f: fig.savefig(f, format=fmt))
        print(f"wrote {args.figure}")
    return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``crandall`` console script; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        resolve(args)  # an option the command would ignore is refused here, naming it
        if args.command == "run":
            return run(args.scene, paths=args.paths, seed=args.seed, threads=args.threads,
                       dt=args.dt, method=args.method, event_depth=args.event_depth,
                       out=args.out, checkpoint=args.checkpoint,
                       scheduler=args.scheduler, figures=not args.no_figures,
                       files=not args.no_files, progress=args.progress,
                       overwrite=args.overwrite, error=args.error, rel_error=args.rel_error,
                       max_seconds=args.max_seconds, statistics=args.statistics,
                       figure_options={"format": args.figure_format, "dpi": args.dpi,
                                       "units": args.figure_units})
        if args.command == "tail":
            return tail_command(args.scene, quantity=args.quantity, levels=args.levels,
                                time=args.time, method=args.method, rel_error=args.rel_error,
                                seed=args.seed, dt=args.dt, threads=args.threads,
                                max_seconds=args.max_seconds, checkpoint=args.checkpoint,
                                mc_paths=args.mc_paths, out=args.out, overwrite=args.overwrite,
                                files=not args.no_files, progress=args.progress,
                                figure_format=args.figure_format, dpi=args.dpi)
        if args.command == "fragility":
            return fragility_command(args)
        if args.command == "scenes":
            return scenes_command()
        if args.command == "newmark":
            return newmark_command(args)
        if args.command == "suite":
            return suite_command(args)
        return analytic_command(args.scene, tau0=args.tau0, times=args.times)
    except (ValueError, StatisticsFailure) as exc:
        # StatisticsFailure: an estimator found no usable answer; its message says what to do.
        print(f"crandall: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a place that fails although it was checked (disk full, ...)
        where = f": {exc.filename}" if getattr(exc, "filename", None) else ""
        print(f"crandall: error{where}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        hint = ("; rerun the same command to resume from the checkpoint"
                if getattr(args, "checkpoint", None) else "")
        print(f"\ncrandall: interrupted{hint}", file=sys.stderr)
        return 130

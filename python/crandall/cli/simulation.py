"""``crandall run`` and ``crandall analytic``: the scene from a file or the paper's, a run
(fixed paths or to an accuracy, on threads or a Dask scheduler), the quantile table it prints
and the analytic layer's table."""

from __future__ import annotations

import math
import sys
import time
from typing import Optional

import numpy as np

from .. import analytic, paper, plots
from ..quantities import quantity
from ..model import ANALYTIC, holds
from ..scene import Scene
from ..simulate import simulate
from ..spec import (MAX_PATHS, check_event_depth, check_int, check_method, check_positive)
from ..errors import ParameterError
from .outputs import DEFAULT_FILE_PATHS, DEFAULT_OUT, PAPER_SEED, _check_out, _write_and_tell


#: The probabilities whose quantiles ``crandall run`` prints for the stop quantities.
QUANTILES = (0.5, 0.9, 0.99, 0.999)

#: A scene file's ``[run]`` fields that ``crandall run --error`` / ``--rel-error`` refuses:
#: they choose how each path is computed, and a run to an accuracy computes with its levels'
#: own method and event depth (docs/methods/adaptive.md), not the ones the file asks for.
REFUSED_WITH_ERROR = ("method", "event_depth")

#: The ``[run]`` fields it leaves unused, with a note on stderr: they size a fixed-step run
#: (how many paths, how fine a grid), which is what a target replaces (a run to an accuracy
#: chooses both to meet it). Every shipped scene sets paths, and one sets dt, so a refusal
#: would break ``crandall run NAME --error EPS``.
UNUSED_WITH_ERROR = ("paths", "dt")


def _read_scene(path: str) -> Scene:
    try:
        return Scene.from_toml(path)
    except UnicodeDecodeError as exc:  # says neither which file nor what is wrong with it
        raise ValueError(f"{path}: not a text (UTF-8) file: {exc.reason} at byte "
                         f"{exc.start}") from None


def _load_scene(path: Optional[str]):
    """The scene and its run settings; the paper's scene when no file is given."""
    if path is None:
        return paper.default_scene(), {"paths": paper.DEFAULT_PATHS, "seed": PAPER_SEED}, True
    scene = _read_scene(path)
    is_paper = scene.to_dict() == paper.default_scene().to_dict()
    return scene, dict(scene.run_settings), is_paper


def run(scene_path: Optional[str] = None, *, paths=None, seed=None, threads=None, dt=None,
        method=None, event_depth=None, out: str = DEFAULT_OUT, checkpoint=None,
        scheduler=None, figures: bool = True, files: bool = True, progress=None,
        overwrite: bool = False,
        error=None, rel_error=None, max_seconds=None, statistics=None,
        figure_options: Optional[dict] = None) -> int:
    """What ``crandall run`` does (arguments as its options); returns the exit status.

    Raises
    ------
    ValueError
        A bad scene file or option, an output folder that cannot be written or holds another
        run's files (without ``overwrite``), a checkpoint that cannot be written or read (the
        message names it). All are checked before the simulation starts.
    OSError
        Writing the outputs failed after the simulation (e.g. the disk is full).
    """
    _refuse_ignored(out=out, overwrite=overwrite, files=files, figures=figures,
                    figure_options=figure_options)
    scene, settings, is_paper = _load_scene(scene_path)
    earlier = _check_out(out, overwrite) if files else []
    if error is not None or rel_error is not None:
        return _run_to_error(scene, settings, error=error, rel_error=rel_error, paths=paths,
                             seed=seed, file=scene_path, threads=threads, dt=dt, method=method,
                             event_depth=event_depth, out=out,
                             checkpoint=checkpoint, scheduler=scheduler, files=files,
                             earlier=earlier, progress=progress, max_seconds=max_seconds,
                             statistics=statistics, figures=figures, is_paper=is_paper,
                             figure_options=figure_options)
    if max_seconds is not None:
        raise ParameterError("--max-seconds", "--max-seconds: only with --error or --rel-error")
    if statistics is not None:
        raise ParameterError("--statistics", "--statistics: only with --error or --rel-error")
    given = {key: value for key, value in (("paths", paths), ("seed", seed), ("dt", dt),
                                           ("method", method), ("event_depth", event_depth))
             if value is not None}
    settings.update(given)
    _check_run_settings(scene, settings, given, scene_path)
    n = settings.get("paths", DEFAULT_FILE_PATHS)
    print(f"crandall: {scene!r}")
    where = f" on {scheduler}" if scheduler else ""
    print(f"simulating {n:,} paths{where} ...", flush=True)
    client = _client(scheduler)
    start = time.perf_counter()
    try:
        result = simulate(scene, paths=n, seed=settings.get("seed"), dt=settings.get("dt"),
                          method=settings.get("method"),
                          event_depth=settings.get("event_depth"), threads=threads,
                          checkpoint=checkpoint, client=client, progress=progress)
        if result.bias_pending:
            # Part of the run: shown in its progress and counted in its time (printing the
            # summary would otherwise make it unannounced).
            print("estimating the bias (coupled grids) ...", flush=True)
            result.estimate_bias()
    finally:
        if client is not None:
            client.close()
    elapsed = time.perf_counter() - start
    # The summary says which statistics are not numbers and why (n/a, n/a* with a note): what
    # follows shows the same statistics without warning of them again.
    with result._table():
        print(result.summary())
        if is_paper:
            print()
            print(paper.comparison(result))
        table = quantile_table(result)
        if table:
            print()
            print(table)
        print(f"\n{result.paths:,} paths x {result.steps_per_path} steps in {elapsed:.1f} s "
              f"(seed {result.seed})")
        if files:
            _write_and_tell(result, out, figures, earlier, figure_options)
    return 0


#: The checks of a fixed-step run's settings that a scene file's [run] table cannot make on
#: its own (a bound of simulate's, or the scene's: a filtered excitation runs with method
#: 'exact' only, white noise has no event depth), in simulate's order, with what a file's
#: field can do about it.
_RUN_CHECKS = (
    ("paths", lambda value, scene: check_int("paths", value, 1, MAX_PATHS),
     "lower it or give --paths"),
    ("dt", lambda value, scene: check_positive("dt", value), "change it or give --dt"),
    ("method", check_method, "change it or give --method"),
    ("event_depth", check_event_depth, "remove it from the file's [run] table"),
)


def _check_run_settings(scene: Scene, settings, given, file: Optional[str]) -> None:
    """Before anything is printed: the run's settings as ``simulate`` would check them, a
    refusal naming where the value came from: the option (``given``: ``--event-depth: ...``)
    or the scene file's field (``FILE: [run] event_depth = 4: ...``)."""
    for key, check, remedy in _RUN_CHECKS:
        if key not in settings:
            continue
        value = settings[key]
        try:
            check(value, scene)
        except ParameterError as exc:
            reason = str(exc)
            for head in (f"{key}: ", f"{key} "):  # the message names the argument: reworded
                if reason.startswith(head):
                    reason = reason[len(head):]
                    break
            if key in given or file is None:
                option = "--" + key.replace("_", "-")
                sep = " " if reason.startswith("must") else ": "
                raise ParameterError(option, f"{option}{sep}{reason}") from None
            raise ParameterError(f"run.{key}", f"{file}: [run] {key} = {value!r}: {reason}; "
                                               f"{remedy}") from None


def _client(scheduler: Optional[str]):
    """A Dask client of the scheduler at this address (None without one)."""
    if not scheduler:
        return None
    try:
        from distributed import Client
    except ImportError:
        raise ValueError("--scheduler needs Dask: pip install 'crandall[distributed]'") from None
    try:
        return Client(scheduler, timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise ParameterError("--scheduler", f"--scheduler: cannot reach {scheduler}: "
                                            f"{exc}") from None
    except (ValueError, TypeError) as exc:  # Dask's word on a malformed address
        raise ParameterError("--scheduler", f"--scheduler: {scheduler!r} is not a scheduler "
                                            f"address: {exc}") from None


def _file_run_with_error(file: str, settings) -> None:
    """Refuse the scene file's ``[run]`` fields a run to an accuracy cannot honour (naming
    them), and say on stderr which ones it leaves unused."""
    for key in REFUSED_WITH_ERROR:
        if key in settings:
            raise ParameterError(f"run.{key}", f"{file}: [run] {key} = {settings[key]!r}: not "
                                 "with --error / --rel-error (a run to an accuracy chooses its "
                                 "grids and paths itself, and its levels keep their own method "
                                 "and event depth); remove it from the file's [run] table, or "
                                 "run without --error / --rel-error")
    unused = [f"{key} = {settings[key]!r}" for key in UNUSED_WITH_ERROR if key in settings]
    if unused:
        print(f"crandall: note: {file}: [run] {' and '.join(unused)} not used: a run to an "
              "accuracy chooses its grids and paths itself; run without --error / --rel-error "
              "to use them", file=sys.stderr)


#: The figure options' defaults (as the command line fills them in).
FIGURE_DEFAULTS = {"format": "png", "dpi": 150, "units": "scene"}


def _refuse_ignored(*, out, overwrite, files, figures, figure_options) -> None:
    """What ``run`` would silently ignore, refused naming it (the command line's parser refuses
    the same beside --no-files and --no-figures; a Python caller gets it here): an output
    folder, ``overwrite`` or figure options with ``files=False``, figure options with
    ``figures=False``. Figure options equal to their defaults change nothing and pass."""
    given = {k: v for k, v in (figure_options or {}).items() if FIGURE_DEFAULTS.get(k, k) != v}
    if not files:
        for name, value in (("out", out != DEFAULT_OUT), ("overwrite", bool(overwrite)),
                            ("figure_options", bool(given))):
            if value:
                raise ParameterError(name, f"{name}: has no effect with files=False (nothing is "
                                           "written); leave out one of them")
    elif not figures and given:
        raise ParameterError("figure_options", "figure_options: "
                             f"{', '.join(sorted(given))} has no effect with figures=False (no "
                             "figures are drawn); leave out one of them")


def note_unused_run_table(file: str, settings, command: str) -> None:
    """Say on stderr that ``command`` (``crandall tail``, ``crandall fragility``) uses none of
    the scene file's ``[run]`` fields: the table holds ``crandall run``'s defaults."""
    if settings:
        fields = ", ".join(f"{key} = {value!r}" for key, value in settings.items())
        print(f"crandall: note: {file}: [run] {fields} not used: the [run] table sets "
              f"crandall run's defaults; {command} takes its seed and step from --seed and "
              "--dt only", file=sys.stderr)


def _run_to_error(scene: Scene, settings, *, error, rel_error, paths, seed, threads, dt, method,
                  event_depth, out, checkpoint, scheduler, files, earlier, progress=None,
                  max_seconds=None, statistics=None, figures: bool = True,
                  is_paper: bool = False, file: Optional[str] = None,
                  figure_options: Optional[dict] = None) -> int:
    """``crandall run --error EPS``: a run to a requested accuracy (``settings``: the scene
    file's ``[run]`` table, read from ``file``)."""
    for option, value in (("--paths", paths), ("--dt", dt), ("--method", method),
                          ("--event-depth", event_depth)):
        if value is not None:
            raise ParameterError(option, f"{option}: not with --error / --rel-error (the run "
                                         "chooses its grids and paths itself)")
    if file is not None:
        _file_run_with_error(file, settings)
    seed = seed if seed is not None else settings.get("seed")
    if seed is None and checkpoint is not None:
        raise ParameterError("--checkpoint", "--checkpoint: give --seed with --error, so that a "
                                             "rerun resumes the same run")
    target = f"error <= {error:g}" if error is not None else f"rel_error <= {rel_error:g}"
    if scene.distributions:
        # A run to an accuracy estimates means and variances; the histograms are a fixed-step
        # run's.
        print(f"crandall: note: a run to an accuracy keeps no histograms, so the scene's "
              f"distributions ({', '.join(scene.distributions)}) are left out; run with "
              "--paths for them", file=sys.stderr)
        scene = Scene.from_dict({**scene.to_dict(), "distributions": None, "bins": None})
    print(f"crandall: {scene!r}")
    where = f" on {scheduler}" if scheduler else ""
    print(f"simulating to {target}{where} ...", flush=True)
    client = _client(scheduler)
    try:
        result = simulate(scene, error=error, rel_error=rel_error, seed=seed, threads=threads,
                          checkpoint=checkpoint, client=client, progress=progress,
                          max_seconds=max_seconds, statistics=statistics)
    finally:
        if client is not None:
            client.close()
    with result._table():  # as in run: the summary says what is not a number
        print(result.summary())
        if is_paper:
            print()
            print(paper.comparison(result))
        c = result.cost
        print(f"\n{c['path_steps']:.3g} path-steps in {c['wall_time']:.1f} s "
              f"(levels {len(c['paths'])}, paths per level {c['paths']}, seed {result.seed})")
        if files:
            _write_and_tell(result, out, figures, earlier, figure_options)
    return 0


def quantile_table(result, names=plots.STOP_DISTRIBUTIONS, probabilities=QUANTILES) -> str:
    """The quantiles of the stop quantities the run holds distributions of, with 95 %
    intervals ("" if none): what ``crandall run`` prints."""
    names = [n for n in names if n in result.distributions]
    if not names:
        return ""
    sc = result.scene
    head = f"  {'quantity':<28}" + "".join(f"{f'{100 * p:g} %':>28} " for p in probabilities)
    lines = ["Quantiles at the stop, from the run's histograms (value [95 % interval]; the "
             "interval is distribution-free and includes the bins' width):", head]
    limited = False
    for n in names:
        unit = sc.units_of(n)
        row = f"  {n + (f' [{unit}]' if unit else ''):<28}"
        for p in probabilities:
            e = result.quantile(n, p)
            mark = "*" if e.bin_limited else " "
            limited |= e.bin_limited
            row += f"{f'{e.value:.4g} [{e.low:.4g}, {e.high:.4g}]{mark}':>29}"
        lines.append(row)
    if limited:
        lines.append("  * the bins account for at least half of this interval: finer bins "
                     "(Scene(bins=...)) would narrow it")
    return "\n".join(lines)


def _analytic_table(scene: Scene) -> str:
    sc = scene
    if not holds(sc, ANALYTIC):
        raise ParameterError("scene", "scene: the analytic layer's closed forms do not hold for "
                                      f"a scene with {', '.join(sorted(sc.effects))}")
    if sc.units == "SI" and sc.scaling is None:
        raise ParameterError("scene", "scene: the analytic layer needs mu > 0 and h > 0 (eq8)")
    if sc.units == "scaled":
        tau, tau0 = sc.times, sc.t0
        tname = "tau"

        def si(value, kind, power=1):
            return value
    else:
        s = sc.scaling
        tau, tau0 = s.to_tau(sc.times), (s.to_tau(sc.t0) if math.isfinite(sc.t0) else math.inf)
        tname = "t [s]"
        si = s.to_si

    def column(c):
        q = quantity(c.quantity)
        power = 1 if c.statistic == "mean" else 2
        unit = sc.units_of(c.quantity)
        unit = unit if power == 1 else "/".join(f"{u}^2" for u in unit.split("/")) if unit else ""
        title = f"{'E' if power == 1 else 'Var'} {c.quantity}" + (f" [{unit}]" if unit else "")

        def value(t):
            return si(c.analytic(t, tau0), q.kind, power)
        return title, value

    cols = [column(c) for c in paper.CURVES]
    units = {"U": "" if sc.units == "scaled" else " [m]"}
    label = "scaled units (eq3)" if sc.units == "scaled" else "SI units"
    lines = [f"crandall analytic: {sc!r}, {label}",
             f"{tname:>10}" + "".join(f"  {name:>24}" for name, _ in cols)]
    for t_out, t in zip(sc.times, np.atleast_1d(tau)):
        row = f"{t_out:>10.4g}"
        for _, f in cols:
            v = float(f(float(t)))
            row += f"  {format(v, '.8g'):>24}"
        lines.append(row)
    if math.isfinite(tau0) and tau0 > 0:
        tu = "" if sc.units == "scaled" else " s"
        lines += [
            "At the stop (eq14):",
            f"  mean stop time            {si(float(analytic.stop_time_mean(tau0)), 'time'):.8g}{tu}",
            f"  var stop time             {si(float(analytic.stop_time_var(tau0)), 'time', 2):.8g}"
            f"{tu and ' s^2'}",
            f"  mean distance at stop     "
            f"{si(float(analytic.distance_at_stop_mean(tau0)), 'length'):.8g}"
            f"{units['U'] and ' m'}  (eq7: tau0/2 in scaled units)",
            f"  var distance at stop      "
            f"{si(float(analytic.distance_at_stop_var(tau0)), 'length', 2):.8g}"
            f"{units['U'] and ' m^2'}",
            f"  var displacement at stop  "
            f"{si(float(analytic.displacement_at_stop_var(tau0)), 'length', 2):.8g}"
            f"{units['U'] and ' m^2'}",
        ]
    return "\n".join(lines)


def analytic_command(scene_path=None, *, tau0=None, times=None) -> int:
    """What ``crandall analytic`` does; returns the exit status."""
    if scene_path is not None and (tau0 is not None or times is not None):
        raise ParameterError("--tau0, --times", "--tau0/--times: give either a scene file or "
                                                "--tau0/--times, not both")
    if scene_path is not None:
        scene = _read_scene(scene_path)
    elif tau0 is None and times is None:
        scene = paper.default_scene()
    else:
        default = paper.default_scene()
        scene = Scene.scaled(tau0=default.t0 if tau0 is None else tau0,
                             times=default.times if times is None else times,
                             observe=["velocity", "displacement", "distance"])
    print(_analytic_table(scene))
    return 0

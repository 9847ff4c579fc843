"""The ``crandall`` command line: ``crandall run [SCENE]``, ``crandall tail [SCENE]``,
``crandall fragility [SCENE]``, ``crandall analytic [SCENE]``, ``crandall scenes`` (the shipped scenes, by name) and
``crandall newmark RECORD`` (Newmark's sliding block on a recorded ground motion).

``crandall run`` without a scene file simulates the paper's setting (``crandall.paper``) and
prints it beside the analytic layer; ``python -m crandall`` does the same.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from . import analytic, paper, plots
from ._version import __version__
from ._files import check_folder_writable, write_atomic
from .methods import DEFAULT_METHOD, METHODS
from .quantities import quantity
from .model import ANALYTIC, holds
from .records import POLARITIES, Record, newmark
from .scene import Scene
from .simulate import simulate
from .spec import draw_seed
from .tail import TAIL_QUANTITIES, StatisticsFailure, tail
from .errors import ParameterError
from .fragility import fragility, hazard_csv, read_hazard_curve

__all__ = ["main", "run", "PAPER_SEED", "DEFAULT_OUT", "DEFAULT_TAIL_OUT"]

#: Seed of the main job (the paper's scene), so that every run prints the same table.
PAPER_SEED = 20261121
#: Paths for a scene file without ``[run] paths``.
DEFAULT_FILE_PATHS = 100_000
#: Where ``crandall run`` writes results and figures, and ``crandall tail`` its table and curve:
#: folders of their own, so that neither's ``--overwrite`` can reach the other's files.
DEFAULT_OUT = "crandall-out"
DEFAULT_TAIL_OUT = "crandall-tail-out"
#: The list of files a run wrote into its output folder (JSON), so that a later run with
#: ``--overwrite`` removes exactly those and nothing of the user's; ``crandall tail`` keeps its
#: own list, so that it never removes what ``crandall run`` wrote into the same folder.
MANIFEST = ".crandall-files.json"
TAIL_MANIFEST = ".crandall-tail-files.json"


@dataclass(frozen=True)
class _Outputs:
    """What one command writes into an output folder: its manifest and the names it may write
    (a folder holding any of them without a manifest, e.g. after a run killed while writing,
    holds an earlier run's files)."""

    manifest: str
    names: Tuple[str, ...]


_RUN_OUTPUTS = _Outputs(MANIFEST, ("result.nc", "result.csv", MANIFEST)
                        + tuple(f"{stem}.{ext}" for ext in plots.FORMATS
                                for stem in ([c.figure for c in paper.CURVES]
                                             + ["velocity_density", "stop_time_density"]
                                             + [f"{n}_distribution"
                                                for n in plots.STOP_DISTRIBUTIONS[1:]])))
_TAIL_OUTPUTS = _Outputs(TAIL_MANIFEST, ("tail.csv", TAIL_MANIFEST)
                         + tuple(f"tail.{ext}" for ext in plots.FORMATS))
#: The probabilities whose quantiles ``crandall run`` prints for the stop quantities.
QUANTILES = (0.5, 0.9, 0.99, 0.999)


def _positive_int(text: str) -> int:
    try:
        value = int(text.replace("_", ""))
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0: {text!r}")
    if value >= 2**64:
        raise argparse.ArgumentTypeError(f"must be < 2**64: {text!r}")
    return value


def _float(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def _floats(text: str) -> List[float]:
    """A comma-separated list of numbers (``0.5,1,2``)."""
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a comma-separated list of numbers: {text!r}") from None


def _progress_options(parser: argparse.ArgumentParser) -> None:
    bar = parser.add_mutually_exclusive_group()
    bar.add_argument("--progress", dest="progress", action="store_const", const=True,
                     help="always show a progress bar")
    bar.add_argument("--no-progress", dest="progress", action="store_const", const=False,
                     help="never show a progress bar (default: on a terminal, for runs "
                          "longer than two seconds)")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="crandall",
        description="A body sliding with Coulomb friction on a white-noise-shaken foundation "
                    "(Crandall's problem): simulation and analytic predictions.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    run = sub.add_parser(
        "run", help="simulate a scene, print its statistics, write results and figures",
        description="Simulate a scene (a TOML file; default: the paper's setting), print the "
                    "summary table (and, for the paper's scene, the comparison with the analytic "
                    "values), and write result.nc (netCDF), result.csv and the figures (PNG) to "
                    "the output folder. Options override the scene file's [run] table.")
    run.add_argument("scene", nargs="?", metavar="SCENE",
                     help="scene file (TOML), or the name of a shipped scene (crandall scenes lists "
                          "them); default: the paper's scene")
    run.add_argument("--paths", type=_positive_int, metavar="N",
                     help=f"paths (default: the file's, else {DEFAULT_FILE_PATHS:,}; "
                          f"{paper.DEFAULT_PATHS:,} for the paper's scene)")
    run.add_argument("--seed", type=_positive_int, metavar="S",
                     help="seed (default: the file's, else drawn and printed; "
                          f"{PAPER_SEED} for the paper's scene)")
    run.add_argument("--threads", type=_positive_int, metavar="T",
                     help="threads (default: all cores; per task with --scheduler: 1)")
    run.add_argument("--dt", type=_float, metavar="DT",
                     help="longest internal step in the scene's time units (default: the "
                          "file's, else crandall.default_dt)")
    run.add_argument("--method", choices=METHODS, help=f"simulation method (default: {DEFAULT_METHOD})")
    target = run.add_mutually_exclusive_group()
    target.add_argument("--error", type=_float, metavar="EPS",
                        help="ask for an accuracy instead of paths: run until the estimated "
                             "total error (bias and statistical) of every statistic is at most "
                             "EPS in the scene's units (multilevel Monte Carlo; writes "
                             "result.csv only)")
    target.add_argument("--rel-error", type=_float, metavar="R",
                        help="the same, relative to each statistic's size")
    run.add_argument("--statistics", nargs="+", metavar="NAME:STAT",
                     help="with --error / --rel-error: the statistics the target applies to, "
                          "e.g. distance:mean distance_at_stop:var (default: every mean and "
                          "variance of the scene)")
    run.add_argument("--max-seconds", type=_float, metavar="S",
                     help="with --error / --rel-error: stop, quoting the estimate, once the "
                          "time spent and the estimated time left pass S (default 3600)")
    run.add_argument("--out", default=DEFAULT_OUT, metavar="DIR",
                     help=f"output folder (default: ./{DEFAULT_OUT}); one that holds another "
                          "run's files is refused unless --overwrite")
    run.add_argument("--overwrite", "--force", dest="overwrite", action="store_true",
                     help="replace the files an earlier run wrote in --out (only those: "
                          "other files are kept)")
    run.add_argument("--checkpoint", metavar="PATH",
                     help="keep finished chunks in PATH; rerunning the same command resumes")
    run.add_argument("--scheduler", metavar="ADDRESS",
                     help="run on a Dask distributed cluster, e.g. tcp://host:8786 "
                          "(pip install 'crandall[distributed]')")
    run.add_argument("--no-figures", action="store_true", help="do not draw the figures")
    run.add_argument("--format", dest="figure_format", choices=plots.FORMATS, default="png",
                     help="the figures' file format (default: png)")
    run.add_argument("--dpi", type=_positive_int, default=150, metavar="N",
                     help="the resolution of png figures (default: 150)")
    run.add_argument("--units", dest="figure_units", choices=plots.UNITS, default="scene",
                     help="draw the figures in the scene's units (default) or the paper's "
                          "scaled units")
    run.add_argument("--no-files", action="store_true",
                     help="print only: write no results or figures")
    _progress_options(run)

    tl = sub.add_parser(
        "tail", help="estimate small tail probabilities P(Q > level) down to 1e-12",
        description="Estimate P(Q > level) of one quantity of a scene at each level, to a "
                    "relative error, by adaptive multilevel splitting on exact paths (or "
                    "importance sampling); print the table and write tail.csv and the "
                    "exceedance curve tail.png: from P = 0.9 down to the largest level, with its 95 % "
                    "band, joined to plain Monte Carlo where that is informative.")
    tl.add_argument("scene", nargs="?", metavar="SCENE",
                    help="scene file (TOML), or the name of a shipped scene (crandall scenes lists "
                          "them); default: the paper's scene")
    tl.add_argument("--quantity", required=True, metavar="Q",
                    help="stop_time, velocity, speed (with --time), distance_at_stop, "
                         "dissipated_energy_at_stop, displacement_at_stop, residual_displacement, "
                         "peak_displacement_at_stop, peak_speed_at_stop")
    tl.add_argument("--levels", type=_float, nargs="+", required=True, metavar="L",
                    help="levels in the scene's units, increasing")
    tl.add_argument("--time", type=_float, metavar="T", help="output time of velocity and speed")
    tl.add_argument("--method", choices=("splitting", "importance"), default="splitting",
                    help="splitting (default) or importance sampling")
    tl.add_argument("--rel-error", type=_float, default=0.1, metavar="R",
                    help="target relative error at every level (default 0.1)")
    tl.add_argument("--seed", type=_positive_int, metavar="S", help="seed (default: drawn and printed)")
    tl.add_argument("--dt", type=_float, metavar="DT", help="grid step (default: crandall.default_dt)")
    tl.add_argument("--threads", type=_positive_int, metavar="T", help="threads (default: all cores)")
    tl.add_argument("--max-seconds", type=_float, default=3600.0, metavar="S",
                    help="bound on the run's time, pilots included (default 3600)")
    tl.add_argument("--checkpoint", metavar="PATH",
                    help="keep finished samples in PATH; rerunning the same command resumes")
    tl.add_argument("--mc-paths", type=_positive_int, default=20_000, metavar="N",
                    help="paths of the plain Monte Carlo part of the curve (default 20000)")
    tl.add_argument("--out", default=DEFAULT_TAIL_OUT, metavar="DIR",
                    help=f"output folder (default: ./{DEFAULT_TAIL_OUT}); one that holds an "
                         "earlier tail run's files is refused unless --overwrite")
    tl.add_argument("--overwrite", "--force", dest="overwrite", action="store_true",
                    help="replace the files an earlier crandall tail wrote in --out (only "
                         "those: crandall run's results and other files are kept)")
    tl.add_argument("--no-files", action="store_true", help="print only")
    tl.add_argument("--format", dest="figure_format", choices=plots.FORMATS, default="png",
                    help="the figure's file format (default: png)")
    tl.add_argument("--dpi", type=_positive_int, default=150, metavar="N",
                    help="the resolution of a png figure (default: 150)")
    _progress_options(tl)

    fr = sub.add_parser(
        "fragility", help="fragility curves: P(Q > threshold) over a grid of intensities or mu",
        description="Estimate P(Q > threshold) of one quantity at each threshold over a grid "
                    "of intensities h, of frictions mu, or of both (a curve over h for each "
                    "mu), each grid point a tail run with its 95 % interval (points of one "
                    "scaled duration t0 (mu g)^2 / (2 h^2) share one run on the paper's "
                    "scene); print the table and the lognormal fit per threshold (per mu), "
                    "and with --hazard the annual rate of exceeding each threshold.")
    fr.add_argument("scene", nargs="?", metavar="SCENE",
                    help="scene file (TOML), or the name of a shipped scene; default: the "
                         "crate (crandall scenes lists them)")
    fr.add_argument("--quantity", required=True, metavar="Q",
                    help="a tail quantity: distance_at_stop, stop_time, residual_displacement, ...")
    fr.add_argument("--thresholds", type=_floats, required=True, metavar="D1,D2,...",
                    help="thresholds in the scene's units, increasing, > 0")
    grid = fr.add_argument_group("the grid (one of them, or both: their product)")
    grid.add_argument("--intensities", type=_floats, metavar="H1,H2,...",
                      help="intensities h, m s^-3/2 (an envelope's scale)")
    grid.add_argument("--mu", type=_floats, metavar="MU1,MU2,...", help="frictions mu")
    fr.add_argument("--time", type=_float, metavar="T", help="output time of velocity and speed")
    fr.add_argument("--method", choices=("splitting", "importance"), default="splitting",
                    help="splitting (default) or importance sampling")
    fr.add_argument("--rel-error", type=_float, default=0.1, metavar="R",
                    help="target relative error of each run (default 0.1)")
    fr.add_argument("--seed", type=_positive_int, metavar="S", help="seed (default: drawn and printed)")
    fr.add_argument("--dt", type=_float, metavar="DT", help="grid step, s (default: each point's "
                                                          "default step)")
    fr.add_argument("--threads", type=_positive_int, metavar="T", help="threads (default: all cores)")
    fr.add_argument("--max-seconds", type=_float, default=3600.0, metavar="S",
                    help="bound on each run's time (default 3600)")
    fr.add_argument("--save", metavar="PATH", help="write the result (netCDF)")
    fr.add_argument("--figure", metavar="PATH", help="draw the curves with their fit (png, pdf, "
                                                     "svg), and the hazard with --hazard")
    hz = fr.add_argument_group("the hazard (a grid over intensities)")
    hz.add_argument("--hazard", metavar="FILE",
                    help="a site's hazard curve: a CSV of two columns, the intensity h "
                         "(m s^-3/2, increasing) and the annual rate of shaking stronger than "
                         "it (non-increasing); '#' lines and one header line skipped. Prints "
                         "the annual rate of exceeding each threshold with its 95 %% interval")
    hz.add_argument("--hazard-use", choices=("fit", "estimates"), default="fit",
                    help="integrate the lognormal fit (default) or the grid's own estimates")
    hz.add_argument("--hazard-save", metavar="PATH",
                    help="write the annual rates (CSV: threshold, rate, stderr, 95 %% interval)")
    _progress_options(fr)

    sub.add_parser(
        "scenes", help="list the scenes shipped with crandall",
        description="List the scenes shipped with crandall, by name and title. Give a name "
                    "where a scene file goes: crandall run crate, crandall tail crate ..., "
                    "crandall.Scene.from_toml(\"crate\").")

    an = sub.add_parser(
        "analytic", help="print the analytic curves",
        description="Print the analytic mean distance and the variances of velocity, "
                    "displacement and distance (paper eq10r-eq10u and the switch-off formulas), "
                    "and the stop statistics, at the scene's output times: in scaled units for "
                    "a scaled scene, in SI for a physical one. Default: the paper's scene.")
    an.add_argument("scene", nargs="?", metavar="SCENE", help="scene file (TOML)")
    an.add_argument("--tau0", type=_float, metavar="TAU0",
                    help="scaled switch-off time instead of a scene (default 5)")
    an.add_argument("--times", type=_float, nargs="+", metavar="TAU",
                    help="scaled output times (with --tau0; default: the paper's)")

    nm = sub.add_parser(
        "newmark", help="Newmark's sliding block on a recorded ground motion",
        description="Slide a rigid block on a recorded ground motion and print its "
                    "displacement: one-way above --ky (SLAMMER's rigid block), two-way on a "
                    "flat surface (--mu, --mu-static) or on an incline (--kd, --ku); yields "
                    "in g (9.80665 m/s^2). The record: a text file of two columns (time, "
                    "acceleration; pySLAMMER's CSV files), one column (with --dt), or a PEER "
                    "NGA .AT2 file. Several yield values sweep them.")
    nm.add_argument("record", metavar="RECORD", help="the record's file")
    mode = nm.add_argument_group("the block (one of --ky, --mu, --kd with --ku)")
    mode.add_argument("--ky", type=_float, nargs="+", metavar="KY",
                      help="one-way yield acceleration(s), g")
    mode.add_argument("--mu", type=_float, nargs="+", metavar="MU",
                      help="two-way on a flat surface: kinetic friction coefficient(s)")
    mode.add_argument("--mu-static", type=_float, nargs="+", metavar="MU",
                      help="with --mu: static friction coefficient(s) (default: --mu)")
    mode.add_argument("--kd", type=_float, nargs="+", metavar="KD",
                      help="incline: downslope yield acceleration(s), g")
    mode.add_argument("--ku", type=_float, nargs="+", metavar="KU",
                      help="incline: upslope yield acceleration(s), g")
    nm.add_argument("--method", choices=("exact", "slammer"), default="exact",
                    help="exact: the record joined by straight lines, integrated exactly "
                         "(default); slammer: pySLAMMER 0.2.2's recursion, bit for bit")
    nm.add_argument("--polarity", choices=POLARITIES, default="normal",
                    help="the record as given, negated, or both (default: normal)")
    nm.add_argument("--dt", type=_float, help="sampling interval, s (a one-column file)")
    nm.add_argument("--units", choices=("g", "m/s2", "cm/s2"), default="g",
                    help="the record's units (default: g)")
    scale = nm.add_mutually_exclusive_group()
    scale.add_argument("--scale", type=_float, metavar="FACTOR", help="multiply the record")
    scale.add_argument("--pga", type=_float, metavar="G", help="scale the record to this PGA, g")
    nm.add_argument("--figure", metavar="FILE",
                    help="write the figure (record, velocity, displacement) of one case to "
                         "FILE (.png, .pdf or .svg)")
    nm.add_argument("--save", metavar="FILE", help="write the result to a netCDF file "
                                                     "(crandall.io.load_newmark reads it)")
    nm.add_argument("--threads", type=_positive_int, help="threads for a sweep (default: all)")
    return parser


def _version() -> str:
    return __version__


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


def _earlier_files(out: str, kind: _Outputs) -> List[str]:
    """The files an earlier run of this kind wrote in ``out``: its manifest's list, and the
    names this kind writes."""
    names = set()
    manifest = os.path.join(out, kind.manifest)
    if os.path.isfile(manifest):
        try:
            with open(manifest, encoding="utf-8") as f:
                listed = json.load(f)
        except (OSError, ValueError):
            listed = []
        if isinstance(listed, list):
            # Bare names only: a manifest cannot point outside its folder.
            names.update(n for n in listed if isinstance(n, str) and n == os.path.basename(n)
                         and n not in ("", ".", ".."))
    names.update(kind.names)
    return sorted(n for n in names if os.path.isfile(os.path.join(out, n)))


def _check_out(out: str, overwrite: bool, kind: _Outputs = _RUN_OUTPUTS) -> List[str]:
    """Before the run: ``out`` is (or can become) a writable folder, and holds no earlier
    files of this kind of run unless ``overwrite``. Returns those files (to remove before
    writing)."""
    check_folder_writable(out, "--out")
    if not os.path.isdir(out):
        return []
    earlier = _earlier_files(out, kind)
    if earlier and not overwrite:
        shown = ", ".join(n for n in earlier if n != kind.manifest) or kind.manifest
        raise ValueError(f"--out: {out} holds the files of an earlier run ({shown}); give "
                         "--overwrite to replace them, or another --out")
    return earlier


def _write_manifest(out: str, written: Sequence[str], failing: bool,
                    manifest: str = MANIFEST) -> None:
    """List the files written in ``out`` (so that a later --overwrite removes them) in this
    kind of run's ``manifest``. When the writing already failed (``failing``: a full disk,
    say), a failure here is dropped: the first error, naming the file it could not write, is
    the one to show."""
    names = json.dumps([os.path.basename(p) for p in written], indent=1).encode()
    try:
        write_atomic(os.path.join(out, manifest), lambda f: f.write(names))
    except OSError:
        if not failing:
            raise


def _write_outputs(result, out: str, figures: bool, earlier: Sequence[str] = (),
                   figure_options: Optional[dict] = None) -> List[str]:
    check_folder_writable(out, "--out", create=True)
    # The earlier run's files go first, so that none of them is left beside the new ones.
    for name in earlier:
        try:
            os.unlink(os.path.join(out, name))
        except FileNotFoundError:
            pass
    written, notes = [], []
    failing = True
    try:
        try:
            path = os.path.join(out, "result.nc")
            result.save(path)
            written.append(path)
            path = os.path.join(out, "result.csv")
            table = result.to_pandas(tidy=True)
            # Atomically, as result.nc: a full disk leaves no torn table and names the file.
            write_atomic(path, lambda f: f.write(table.to_csv(index=False).encode()))
            written.append(path)
        except ImportError as exc:
            notes.append(f"results not written ({exc})")
        if figures:
            try:
                written += plots.write_figures(result, out, **(figure_options or {}))
            except ImportError as exc:
                notes.append(f"figures not drawn ({exc})")
            except ValueError as exc:  # --units scaled for a scene without scaled units
                notes.append(f"figures not drawn: {exc}")
        failing = False
    finally:
        # Even after a failure midway: what was written is listed, so a later --overwrite
        # removes it.
        _write_manifest(out, written, failing)
    for note in notes:
        print(f"crandall: note: {note}", file=sys.stderr)
    return written


def run(scene_path: Optional[str] = None, *, paths=None, seed=None, threads=None, dt=None,
        method=None, out: str = DEFAULT_OUT, checkpoint=None, scheduler=None,
        figures: bool = True, files: bool = True, progress=None, overwrite: bool = False,
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
    scene, settings, is_paper = _load_scene(scene_path)
    earlier = _check_out(out, overwrite) if files else []
    if error is not None or rel_error is not None:
        return _run_to_error(scene, settings, error=error, rel_error=rel_error, paths=paths,
                             seed=seed, threads=threads, dt=dt, method=method, out=out,
                             checkpoint=checkpoint, scheduler=scheduler, files=files,
                             earlier=earlier, progress=progress, max_seconds=max_seconds,
                             statistics=statistics, figures=figures, is_paper=is_paper,
                             figure_options=figure_options)
    if max_seconds is not None:
        raise ValueError("--max-seconds: only with --error or --rel-error")
    if statistics is not None:
        raise ValueError("--statistics: only with --error or --rel-error")
    for key, value in (("paths", paths), ("seed", seed), ("dt", dt), ("method", method)):
        if value is not None:
            settings[key] = value
    n = settings.get("paths", DEFAULT_FILE_PATHS)
    print(f"crandall: {scene!r}")
    where = f" on {scheduler}" if scheduler else ""
    print(f"simulating {n:,} paths{where} ...", flush=True)
    client = _client(scheduler)
    start = time.perf_counter()
    try:
        result = simulate(scene, paths=n, seed=settings.get("seed"), dt=settings.get("dt"),
                          method=settings.get("method"), threads=threads,
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


def _write_and_tell(result, out: str, figures: bool, earlier: Sequence[str],
                    figure_options: Optional[dict] = None) -> None:
    written = _write_outputs(result, out, figures, earlier, figure_options)
    if written:
        print(f"wrote {len(written)} files to {out}{os.sep}: "
              + ", ".join(os.path.basename(p) for p in written))


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
        raise ValueError(f"--scheduler: cannot reach {scheduler}: {exc}") from None
    except (ValueError, TypeError) as exc:  # Dask's word on a malformed address
        raise ValueError(f"--scheduler: {scheduler!r} is not a scheduler address: "
                         f"{exc}") from None


def _run_to_error(scene: Scene, settings, *, error, rel_error, paths, seed, threads, dt, method,
                  out, checkpoint, scheduler, files, earlier, progress=None,
                  max_seconds=None, statistics=None, figures: bool = True,
                  is_paper: bool = False,
                  figure_options: Optional[dict] = None) -> int:
    """``crandall run --error EPS``: a run to a requested accuracy."""
    for option, value in (("--paths", paths), ("--dt", dt), ("--method", method)):
        if value is not None:
            raise ValueError(f"{option}: not with --error / --rel-error (the run chooses its "
                             "grids and paths itself)")
    seed = seed if seed is not None else settings.get("seed")
    if seed is None and checkpoint is not None:
        raise ValueError("--checkpoint: give --seed with --error, so that a rerun resumes "
                         "the same run")
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
        raise ValueError(f"scene: the analytic layer's closed forms do not hold for a scene "
                         f"with {', '.join(sorted(sc.effects))}")
    if sc.units == "SI" and sc.scaling is None:
        raise ValueError("scene: the analytic layer needs mu > 0 and h > 0 (eq8)")
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
        raise ValueError("--tau0/--times: give either a scene file or --tau0/--times, not both")
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
                 mc_paths: int = 20_000, out: str = DEFAULT_TAIL_OUT, overwrite: bool = False,
                 files: bool = True, progress=None, figure_format: str = "png",
                 dpi: int = 150) -> int:
    """``crandall tail``: the table at the given levels, tail.csv, and the curve (tail.png)."""
    scene, settings, _ = _load_scene(scene_path)
    if quantity not in TAIL_QUANTITIES:
        raise ValueError(f"--quantity must be one of {', '.join(TAIL_QUANTITIES)}; got {quantity!r}")
    earlier = _check_out(out, overwrite, _TAIL_OUTPUTS) if files else []
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
        seed = int(np.random.SeedSequence().entropy % (1 << 63))
        print(f"seed: {seed}")
    if args.figure is not None:
        fmt = os.path.splitext(args.figure)[1].lstrip(".").lower()
        if fmt not in plots.FORMATS:
            raise ValueError(f"--figure: the file must end in one of "
                             f"{', '.join('.' + f for f in plots.FORMATS)}")
    curve = None
    if args.hazard is not None:
        if args.intensities is None:
            raise ParameterError("hazard", "--hazard: a hazard curve is one of the intensity; "
                                           "give --intensities")
        curve = read_hazard_curve(args.hazard)  # before the runs: a bad file fails at once
    elif args.hazard_save is not None:
        raise ParameterError("hazard_save", "--hazard-save needs --hazard FILE")
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
        raise ValueError("--figure draws one case: give one yield value and one polarity")
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
            raise ValueError(f"--figure: the file must end in one of "
                             f"{', '.join('.' + f for f in plots.FORMATS)}")
        fig = plots.newmark(result)
        write_atomic(args.figure, lambda f: fig.savefig(f, format=fmt))
        print(f"wrote {args.figure}")
    return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``crandall`` console script; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        if args.command == "run":
            if not 50 <= args.dpi <= 1200:
                raise ValueError(f"--dpi must be between 50 and 1200, got {args.dpi}")
            return run(args.scene, paths=args.paths, seed=args.seed, threads=args.threads,
                       dt=args.dt, method=args.method, out=args.out, checkpoint=args.checkpoint,
                       scheduler=args.scheduler, figures=not args.no_figures,
                       files=not args.no_files, progress=args.progress,
                       overwrite=args.overwrite, error=args.error, rel_error=args.rel_error,
                       max_seconds=args.max_seconds, statistics=args.statistics,
                       figure_options={"format": args.figure_format, "dpi": args.dpi,
                                       "units": args.figure_units})
        if args.command == "tail":
            if not 50 <= args.dpi <= 1200:
                raise ValueError(f"--dpi must be between 50 and 1200, got {args.dpi}")
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""The command line's arguments: the parser of every subcommand and its value checks."""

from __future__ import annotations

import argparse
from typing import List

from .. import paper, plots
from .._version import __version__
from ..methods import DEFAULT_METHOD, MAX_EVENT_DEPTH, METHODS, MIN_EVENT_DEPTH
from ..errors import ParameterError
from ..records import POLARITIES
from .outputs import (DEFAULT_FILE_PATHS, DEFAULT_MC_PATHS, DEFAULT_OUT, DEFAULT_TAIL_OUT,
                      PAPER_SEED)


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


def _block_options(parser: argparse.ArgumentParser) -> None:
    """The Newmark block's options (crandall newmark and crandall suite): its yields in g, one
    or several (a sweep)."""
    block = parser.add_argument_group("the block (one of --ky, --mu, --kd with --ku)")
    block.add_argument("--ky", type=_float, nargs="+", metavar="KY",
                       help="one-way yield acceleration(s), g")
    block.add_argument("--mu", type=_float, nargs="+", metavar="MU",
                       help="two-way on a flat surface: kinetic friction coefficient(s)")
    block.add_argument("--mu-static", type=_float, nargs="+", metavar="MU",
                       help="with --mu: static friction coefficient(s) (default: --mu)")
    block.add_argument("--kd", type=_float, nargs="+", metavar="KD",
                       help="incline: downslope yield acceleration(s), g")
    block.add_argument("--ku", type=_float, nargs="+", metavar="KU",
                       help="incline: upslope yield acceleration(s), g")


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
    run.add_argument("--event-depth", type=_positive_int, metavar="D",
                     help="a filtered excitation's event search: bisections of a step where the "
                          "body may stop or start (default: the file's, else 8; "
                          f"{MIN_EVENT_DEPTH} to {MAX_EVENT_DEPTH})")
    target = run.add_mutually_exclusive_group()
    target.add_argument("--error", type=_float, metavar="EPS",
                        help="ask for an accuracy instead of paths: run until the estimated "
                             "total error (bias and statistical) of every statistic is at most "
                             "EPS in the scene's units (multilevel Monte Carlo). The run "
                             "chooses its grids and paths: a scene file's [run] method and "
                             "event_depth are refused, its paths and dt left unused (said on "
                             "stderr)")
    target.add_argument("--rel-error", type=_float, metavar="R",
                        help="the same, relative to each statistic's size")
    run.add_argument("--statistics", nargs="+", metavar="NAME:STAT",
                     help="with --error / --rel-error: the statistics the target applies to, "
                          "e.g. distance:mean distance_at_stop:var (default: every mean and "
                          "variance of the scene)")
    run.add_argument("--max-seconds", type=_float, metavar="S",
                     help="with --error / --rel-error: stop, quoting the estimate, once the "
                          "time spent and the estimated time left pass S (default 3600)")
    run.add_argument("--out", metavar="DIR",
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
    run.add_argument("--no-figures", action="store_true",
                     help="do not draw the figures (--format, --dpi and --units are then "
                          "refused: they would have no effect)")
    run.add_argument("--format", dest="figure_format", choices=plots.FORMATS,
                     help="the figures' file format (default: png)")
    run.add_argument("--dpi", type=_positive_int, metavar="N",
                     help="the resolution of png figures (default: 150)")
    run.add_argument("--units", dest="figure_units", choices=plots.UNITS,
                     help="draw the figures in the scene's units (default) or the paper's "
                          "scaled units")
    run.add_argument("--no-files", action="store_true",
                     help="print only: write no results or figures (--out, --overwrite, "
                          "--format, --dpi and --units are then refused: they would have no "
                          "effect)")
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
    tl.add_argument("--mc-paths", type=_positive_int, metavar="N",
                    help="paths of the plain Monte Carlo part of the curve (default "
                         f"{DEFAULT_MC_PATHS}; "
                         "a quantity at the stop only: stop_time, distance_at_stop, "
                         "dissipated_energy_at_stop, displacement_at_stop, "
                         "residual_displacement)")
    tl.add_argument("--out", metavar="DIR",
                    help=f"output folder (default: ./{DEFAULT_TAIL_OUT}); one that holds an "
                         "earlier tail run's files is refused unless --overwrite")
    tl.add_argument("--overwrite", "--force", dest="overwrite", action="store_true",
                    help="replace the files an earlier crandall tail wrote in --out (only "
                         "those: crandall run's results and other files are kept)")
    tl.add_argument("--no-files", action="store_true",
                    help="print only (--out, --overwrite, --format, --dpi and --mc-paths are "
                         "then refused: they would have no effect)")
    tl.add_argument("--format", dest="figure_format", choices=plots.FORMATS,
                    help="the figure's file format (default: png)")
    tl.add_argument("--dpi", type=_positive_int, metavar="N",
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
    hz.add_argument("--hazard-use", choices=("fit", "estimates"),
                    help="with --hazard: integrate the lognormal fit (default) or the grid's "
                         "own estimates")
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

    su = sub.add_parser(
        "suite", help="a suite of records as a fragility curve (Newmark's block on each)",
        description="The weighted fraction of records whose Newmark displacement exceeds each "
                    "threshold, per yield value (and per PGA the records are scaled to), with "
                    "its 95 %% interval (Clopper-Pearson at Kish's effective number of "
                    "records) and the lognormal fit per threshold. Records as for crandall "
                    "newmark; yields in g. With --model (a saved crandall fragility) and "
                    "--figure, the records' curves are drawn beside the model's.")
    su.add_argument("records", nargs="+", metavar="RECORD", help="the records' files")
    su.add_argument("--thresholds", type=_floats, required=True, metavar="D1,D2,...",
                    help="displacements, m: increasing, > 0")
    _block_options(su)
    su.add_argument("--pga", type=_floats, metavar="G1,G2,...",
                    help="scale every record to each of these PGAs, g (an axis: a curve over PGA)")
    su.add_argument("--weights", type=_floats, metavar="W1,W2,...",
                    help="one weight per record, >= 0 (default: equal)")
    su.add_argument("--polarity", choices=POLARITIES, default="both",
                    help="both (default: each record counts in both, half its weight each), "
                         "normal or inverse")
    su.add_argument("--measure", choices=("displacement", "peak_displacement"),
                    default="displacement",
                    help="|displacement at the record's end| (default) or its largest |value|")
    su.add_argument("--method", choices=("exact", "slammer"), default="exact",
                    help="as for crandall newmark (default: exact)")
    su.add_argument("--dt", type=_float, help="sampling interval, s (one-column files)")
    su.add_argument("--units", choices=("g", "m/s2", "cm/s2"), default="g",
                    help="the records' units (default: g)")
    su.add_argument("--model", metavar="PATH",
                    help="a saved stochastic fragility (crandall fragility --save) drawn "
                         "beside the records' on --figure")
    su.add_argument("--save", metavar="PATH", help="write the result (netCDF; "
                                                    "crandall.fragility.load reads it)")
    su.add_argument("--figure", metavar="PATH", help="draw the curves (png, pdf, svg)")
    su.add_argument("--threads", type=_positive_int, help="threads (default: all cores)")

    nm = sub.add_parser(
        "newmark", help="Newmark's sliding block on a recorded ground motion",
        description="Slide a rigid block on a recorded ground motion and print its "
                    "displacement: one-way above --ky (SLAMMER's rigid block), two-way on a "
                    "flat surface (--mu, --mu-static) or on an incline (--kd, --ku); yields "
                    "in g (9.80665 m/s^2). The record: a text file of two columns (time, "
                    "acceleration; pySLAMMER's CSV files), one column (with --dt), or a PEER "
                    "NGA .AT2 file. Several yield values sweep them.")
    nm.add_argument("record", metavar="RECORD", help="the record's file")
    _block_options(nm)
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


#: What each command writes, and so the options that only shape what it writes: refused
#: beside the flag that writes none of it (given, they would be silently ignored). The parser
#: leaves them None (False for --overwrite) so that one given can be told from one left out;
#: :func:`resolve` fills in the defaults. (flag's attribute, flag, what it leaves out,
#: options as (flag, attribute)).
_FIGURE_OPTIONS = (("--format", "figure_format"), ("--dpi", "dpi"), ("--units", "figure_units"))
_IGNORED = {
    "run": (("no_files", "--no-files", "nothing is written",
             (("--out", "out"), ("--overwrite", "overwrite")) + _FIGURE_OPTIONS),
            ("no_figures", "--no-figures", "no figures are drawn", _FIGURE_OPTIONS)),
    "tail": (("no_files", "--no-files", "nothing is written",
              (("--out", "out"), ("--overwrite", "overwrite"), ("--format", "figure_format"),
               ("--dpi", "dpi"), ("--mc-paths", "mc_paths"))),),
}
_DEFAULTS = {
    "run": {"out": DEFAULT_OUT, "figure_format": "png", "dpi": 150, "figure_units": "scene"},
    # --mc-paths: tail_command's default, which also refuses it for a quantity without a plain
    # Monte Carlo part.
    "tail": {"out": DEFAULT_TAIL_OUT, "figure_format": "png", "dpi": 150},
    "fragility": {"hazard_use": "fit"},
}


def resolve(args: argparse.Namespace) -> argparse.Namespace:
    """Check the parsed ``args`` beyond what argparse does and fill in the defaults it left
    None: an option that the command would ignore beside ``--no-files`` or ``--no-figures``
    (or ``--hazard-use`` without ``--hazard``) is refused with a ParameterError naming both,
    so that nothing a user asked for is silently dropped."""
    command = args.command
    dpi = getattr(args, "dpi", None)
    if dpi is not None and not 50 <= dpi <= 1200:
        raise ParameterError("--dpi", f"--dpi must be between 50 and 1200, got {dpi}")
    for flag_name, flag, effect, options in _IGNORED.get(command, ()):
        if not getattr(args, flag_name):
            continue
        for option, name in options:
            value = getattr(args, name)
            if value is not None and value is not False:  # given (0 is a value: not False)
                spelled = "--overwrite (--force)" if option == "--overwrite" else option
                raise ParameterError(option, f"{spelled} has no effect with {flag} ({effect}); "
                                             f"leave out one of them")
    if command == "fragility" and args.hazard_use is not None and args.hazard is None:
        raise ParameterError("--hazard-use", "--hazard-use has no effect without --hazard FILE "
                                             "(no hazard curve is integrated)")
    for name, value in _DEFAULTS.get(command, {}).items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    return args


def _version() -> str:
    return __version__

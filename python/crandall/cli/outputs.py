"""The command line's output folders: the defaults, the manifest of the files a command
wrote (so that ``--overwrite`` removes exactly those), and the writing of a run's result,
tables and figures."""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

from .. import paper, plots
from .._files import check_folder_writable, write_atomic
from ..errors import ParameterError


#: Seed of the main job (the paper's scene), so that every run prints the same table.
PAPER_SEED = 20261121


#: Paths for a scene file without ``[run] paths``.
DEFAULT_FILE_PATHS = 100_000


#: Where ``crandall run`` writes results and figures, and ``crandall tail`` its table and curve:
#: folders of their own, so that neither's ``--overwrite`` can reach the other's files.
DEFAULT_OUT = "crandall-out"


DEFAULT_TAIL_OUT = "crandall-tail-out"


#: Paths of the plain Monte Carlo part of ``crandall tail``'s curve without ``--mc-paths``.
DEFAULT_MC_PATHS = 20_000


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


_TAIL_OUTPUTS = _Outputs(TAIL_MANIFEST, ("tail.csv", "tail.nc", TAIL_MANIFEST)
                         + tuple(f"tail.{ext}" for ext in plots.FORMATS))


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
        raise ParameterError("--out", f"--out: {out} holds the files of an earlier run ({shown}); "
                                      "give --overwrite to replace them, or another --out")
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


def _write_and_tell(result, out: str, figures: bool, earlier: Sequence[str],
                    figure_options: Optional[dict] = None) -> None:
    written = _write_outputs(result, out, figures, earlier, figure_options)
    if written:
        print(f"wrote {len(written)} files to {out}{os.sep}: "
              + ", ".join(os.path.basename(p) for p in written))

"""The command line: crandall run / analytic, --help, errors, outputs, python -m crandall."""

import errno
import importlib.metadata
import importlib.util
import json
import os
import pathlib
import re
import runpy
import subprocess
import sys
import tempfile

import numpy as np
import pytest

import crandall
from crandall import analytic, cli
from conftest import same_result

SCENES = pathlib.Path(__file__).resolve().parent.parent / "python" / "crandall" / "scenes"
SMALL = """
title = "small"
[scene]
units = "scaled"
tau0 = 1.0
times = { start = 0.5, stop = 2.0, step = 0.5 }
[run]
paths = 3000
seed = 12
dt = 0.05
"""


@pytest.fixture
def scene_file(tmp_path):
    """The small scene SMALL, written to tmp_path / "small.toml"."""
    path = tmp_path / "small.toml"
    path.write_text(SMALL)
    return path


def crandall_cmd(*args, cwd=None, timeout=120):
    return subprocess.run([sys.executable, "-m", "crandall", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd)


def test_console_script_is_declared():
    eps = importlib.metadata.entry_points(group="console_scripts")
    assert any(ep.name == "crandall" and ep.value == "crandall.cli:main" for ep in eps)


@pytest.mark.parametrize("args", [["--help"], ["run", "--help"], ["analytic", "--help"], ["tail", "--help"],
                                  ["scenes", "--help"], ["fragility", "--help"]])
def test_help_everywhere(args):
    proc = crandall_cmd(*args)
    assert proc.returncode == 0, proc.stderr
    assert "usage: crandall" in proc.stdout
    if args[0] == "run":
        for option in ("--paths", "--seed", "--threads", "--dt", "--method", "--out",
                       "--checkpoint", "--scheduler"):
            assert option in proc.stdout


def test_run_scene_file_prints_and_writes_everything(scene_file, tmp_path):
    out = tmp_path / "out"
    proc = crandall_cmd("run", str(scene_file), "--out", str(out), "--threads", "1")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""  # no progress bar off a terminal
    direct = crandall.simulate(crandall.Scene.from_toml(scene_file), paths=3000, seed=12,
                               dt=0.05)
    assert direct.estimate_bias().summary() in proc.stdout
    files = sorted(p.name for p in out.iterdir())
    outputs = sorted(["result.nc", "result.csv", "fig2_distance_mean.png",
                      "fig3_velocity_var.png", "fig4_displacement_var.png",
                      "fig5_distance_var.png", "velocity_density.png", "stop_time_density.png"])
    assert files == sorted(outputs + [cli.MANIFEST])
    assert sorted(json.loads((out / cli.MANIFEST).read_text())) == outputs
    assert same_result(crandall.load(out / "result.nc"), direct)
    csv = (out / "result.csv").read_text().splitlines()
    # Tidy: one row per quantity, time and statistic (9 of them), each with its own unit.
    assert csv[0] == "quantity,time,time_units,statistic,value,units"
    assert len(csv) == 1 + (5 * 4 + 4) * 9
    assert csv[1].startswith("velocity,0.5,1,mean,") and csv[1].endswith(",1")
    for png in out.glob("*.png"):
        assert png.stat().st_size > 10_000


def test_options_override_the_file(scene_file, tmp_path, capsys):
    assert cli.main(["run", str(scene_file), "--paths", "2000", "--seed", "4", "--dt", "0.1",
                     "--method", "euler", "--no-files"]) == 0
    out = capsys.readouterr().out
    direct = crandall.simulate(crandall.Scene.from_toml(scene_file), paths=2000, seed=4,
                               dt=0.1, method="euler")
    assert direct.estimate_bias().summary() in out
    assert not (tmp_path / cli.DEFAULT_OUT).exists()


def test_checkpoint_option_resumes(scene_file, tmp_path, capsys):
    ckpt = tmp_path / "run.ckpt"
    args = ["run", str(scene_file), "--no-files", "--checkpoint", str(ckpt)]
    assert cli.main(args) == 0
    first = capsys.readouterr().out
    assert ckpt.exists()
    assert cli.main(args) == 0
    again = capsys.readouterr().out
    table = lambda text: [l for l in text.splitlines() if " steps in " not in l]  # noqa: E731
    assert table(first) == table(again)
    assert cli.main(args[:-1] + [str(ckpt), "--seed", "13"]) == 2
    assert "different run" in capsys.readouterr().err


@pytest.mark.parametrize("text, key", [
    ("[scene]\nunits = 'scaled'\ntau0 = -1\ntimes = [1]\n", "scene.tau0"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\n[run]\npaths = 'many'\n", "run.paths"),
])
def test_bad_scene_file_exits_nonzero_naming_file_and_key(tmp_path, text, key):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    proc = crandall_cmd("run", str(bad), "--out", str(tmp_path / "o"))
    assert proc.returncode == 2
    assert f"crandall: error: {bad}: {key}: " in proc.stderr
    assert not (tmp_path / "o").exists()


def test_bad_options_exit_nonzero(tmp_path):
    assert crandall_cmd("run", "--paths", "lots").returncode == 2
    assert crandall_cmd("run", "--method", "rk4").returncode == 2
    proc = crandall_cmd("run", str(tmp_path / "missing.toml"))
    assert proc.returncode == 2 and "missing.toml: cannot read" in proc.stderr
    proc = crandall_cmd("run", "--paths", "0", "--no-files")
    assert proc.returncode == 2 and "paths must be >= 1" in proc.stderr


def test_python_m_crandall_is_crandall_run_on_the_paper_scene(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(crandall.paper, "DEFAULT_PATHS", 2000)
    monkeypatch.setattr(sys, "argv", ["crandall"])
    with pytest.raises(SystemExit) as info:
        runpy.run_module("crandall", run_name="__main__")
    assert info.value.code == 0
    via_m = capsys.readouterr().out
    monkeypatch.chdir(tmp_path / "..")
    assert cli.main(["run", "--out", str(tmp_path / "again")]) == 0
    via_run = capsys.readouterr().out
    strip = lambda t: [l for l in t.splitlines() if " steps in " not in l and "wrote" not in l]  # noqa: E731
    assert strip(via_m) == strip(via_run)
    assert "Energy law (eq7)" in via_m  # the paper's comparison is printed
    assert f"seed={cli.PAPER_SEED}" in via_m
    assert (tmp_path / cli.DEFAULT_OUT / "result.nc").exists()
    # The shipped paper.toml is the same run.
    assert cli.main(["run", str(SCENES / "paper.toml"), "--paths", "2000", "--no-files"]) == 0
    assert strip(capsys.readouterr().out)[1:] == strip(via_m)[1:]


def test_analytic_command(capsys):
    assert cli.main(["analytic"]) == 0
    out = capsys.readouterr().out
    row = [l for l in out.splitlines() if l.split() and l.split()[0] == "5"][0]
    values = [float(v) for v in row.split()[1:]]
    np.testing.assert_allclose(values, [analytic.distance_mean(5.0), analytic.velocity_var(5.0),
                                        analytic.displacement_var(5.0),
                                        analytic.distance_var(5.0)], rtol=1e-7)
    assert "mean stop time" in out
    assert cli.main(["analytic", "--tau0", "1", "--times", "0.5", "2"]) == 0
    out = capsys.readouterr().out
    # After the switch-off every column has its analytic value (no blank columns).
    row = re.search(r"\n\s+2\s+0\.49920073\s+0\.0031970974\s+(\S+)\s+(\S+)\n", out)
    assert row, out
    np.testing.assert_allclose([float(row.group(1)), float(row.group(2))],
                               [analytic.displacement_var(2.0, 1.0),
                                analytic.distance_var(2.0, 1.0)], rtol=1e-7)
    assert cli.main(["analytic", str(SCENES / "crate.toml")]) == 0
    out = capsys.readouterr().out
    expected = analytic.physical("distance_mean", 1.0, mu=0.3, h=1.0, t0=2.0)
    assert f"{expected:.8g}" in out and "[m]" in out
    assert cli.main(["analytic", str(SCENES / "crate.toml"), "--tau0", "1"]) == 2


def test_scenes_lists_the_shipped_scenes_and_run_takes_a_name(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # an empty folder: the names need no file here
    assert cli.main(["scenes"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [l.split()[0] for l in lines] == sorted(p.stem for p in SCENES.glob("*.toml"))
    assert any(l.startswith("crate ") and "truck bed" in l for l in lines)
    assert cli.main(["analytic", "crate"]) == 0
    by_name = capsys.readouterr().out
    assert cli.main(["analytic", str(SCENES / "crate.toml")]) == 0
    assert capsys.readouterr().out == by_name
    assert cli.main(["run", "vibrating_table", "--paths", "2000", "--seed", "1",
                     "--no-files"]) == 0
    assert "Scene(mu=0.15, h=0.5, t0=0.5, g=9.81, mass=0.02" in capsys.readouterr().out
    assert cli.main(["run", "no_such_scene", "--no-files"]) == 2
    assert "crandall scenes" in capsys.readouterr().err


# -- output folder, checkpoint and bad input: exit 2 with one line, before simulating -------

VELOCITY_ONLY = SMALL.replace('tau0 = 1.0', 'tau0 = 1.0\nobserve = ["velocity"]')


def _no_simulation(monkeypatch):
    def boom(*args, **kwargs):
        raise AssertionError("simulated although the command was refused")
    for module in ("simulation", "commands"):  # where the command line calls simulate
        monkeypatch.setattr(importlib.import_module(f"crandall.cli.{module}"), "simulate", boom)


def _one_line_error(capsys, *words):
    err = capsys.readouterr().err
    assert err.startswith("crandall: error: ") and err.count("\n") == 1, err
    for word in words:
        assert word in err, err
    return err


def test_second_run_into_the_same_out_is_refused(scene_file, tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    args = ["run", str(scene_file), "--out", str(out), "--no-figures"]
    assert cli.main(args) == 0
    capsys.readouterr()
    first = {p.name: p.read_bytes() for p in out.iterdir()}
    _no_simulation(monkeypatch)
    assert cli.main(args) == 2
    _one_line_error(capsys, "--out", str(out), "earlier run", "result.nc", "--overwrite")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == first  # untouched


def test_overwrite_replaces_only_the_earlier_runs_files(tmp_path, capsys):
    full = tmp_path / "full.toml"
    full.write_text(SMALL)
    velocity = tmp_path / "velocity.toml"
    velocity.write_text(VELOCITY_ONLY)
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert cli.main(["run", str(full), "--out", str(out)]) == 0
    assert (out / "fig5_distance_var.png").exists() and (out / "stop_time_density.png").exists()
    for flag in ("--overwrite", "--force"):
        assert cli.main(["run", str(velocity), "--out", str(out), flag]) == 0
        # Nothing of the first scene's is left beside the second one's results.
        new = ["fig3_velocity_var.png", "result.csv", "result.nc", "velocity_density.png"]
        assert sorted(p.name for p in out.iterdir()) == sorted(new + [cli.MANIFEST,
                                                                      "notes.txt"])
        assert sorted(json.loads((out / cli.MANIFEST).read_text())) == new
        assert (out / "notes.txt").read_text() == "mine"
        assert crandall.load(out / "result.nc").scene.observe == ("velocity",)
    capsys.readouterr()


def test_a_manifest_never_reaches_outside_its_folder(scene_file, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "precious.txt").write_text("keep")
    (out / cli.MANIFEST).write_text(json.dumps(["../precious.txt", str(tmp_path / "precious.txt"),
                                                "result.nc"]))
    assert cli.main(["run", str(scene_file), "--out", str(out), "--no-figures"]) == 2
    _one_line_error(capsys, cli.MANIFEST)
    assert cli.main(["run", str(scene_file), "--out", str(out), "--no-figures",
                     "--overwrite"]) == 0
    assert (tmp_path / "precious.txt").read_text() == "keep"


def test_earlier_outputs_without_a_manifest_are_refused(scene_file, tmp_path, monkeypatch, capsys):
    """A run killed while writing leaves crandall's files without a manifest."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "fig2_distance_mean.png").write_bytes(b"png")
    (out / "other.txt").write_text("x")
    _no_simulation(monkeypatch)
    assert cli.main(["run", str(scene_file), "--out", str(out)]) == 2
    _one_line_error(capsys, "fig2_distance_mean.png")


def test_folder_with_only_other_files_is_used(scene_file, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "other.txt").write_text("x")
    assert cli.main(["run", str(scene_file), "--out", str(out), "--no-figures"]) == 0
    assert (out / "result.nc").exists() and (out / "other.txt").read_text() == "x"


@pytest.mark.parametrize("where, words", [
    ("afile", ["--out must be a directory", "afile is a file"]),
    ("afile/sub", ["--out: cannot create", "is a file"]),
    ("", ["--out must be a folder path"]),
])
def test_unwritable_out_fails_before_the_run(scene_file, tmp_path, monkeypatch, capsys, where,
                                             words):
    (tmp_path / "afile").write_text("x")
    monkeypatch.chdir(tmp_path)
    _no_simulation(monkeypatch)
    assert cli.main(["run", str(scene_file), "--out", where]) == 2
    _one_line_error(capsys, *words)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "small.toml"]


def _read_only_places():
    return [pytest.param("chmod", marks=pytest.mark.skipif(
                os.geteuid() == 0, reason="root writes into read-only folders")),
            pytest.param("/sys", marks=pytest.mark.skipif(
                not os.path.isdir("/sys"), reason="needs /sys"))]


@pytest.mark.parametrize("kind", _read_only_places())
def test_read_only_out_fails_before_the_run(scene_file, tmp_path, monkeypatch, capsys, kind):
    if kind == "chmod":
        place = tmp_path / "ro"
        place.mkdir()
        place.chmod(0o500)
    else:
        place = pathlib.Path(kind)
        try:  # it must really refuse (it does in containers and for non-root users)
            fd, name = tempfile.mkstemp(dir=place)
        except OSError:
            pass
        else:
            os.close(fd)
            os.unlink(name)
            pytest.skip(f"{place} is writable here")
    _no_simulation(monkeypatch)
    try:
        for out in (place, place / "sub"):
            assert cli.main(["run", str(scene_file), "--out", str(out)]) == 2
            _one_line_error(capsys, "--out: cannot write in", str(place))
    finally:
        if kind == "chmod":
            place.chmod(0o700)


def test_failed_write_after_the_run_is_one_line_not_a_traceback(scene_file, tmp_path, monkeypatch,
                                                                capsys):
    def disk_full(result, path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(crandall._dataset, "save", disk_full)
    assert cli.main(["run", str(scene_file), "--out", str(tmp_path / "o"), "--no-figures"]) == 2
    _one_line_error(capsys, "result.nc", os.strerror(errno.ENOSPC))


def test_a_full_disk_while_saving_is_one_line_naming_the_file(scene_file, tmp_path,
                                                               monkeypatch, capsys):
    """A disk that fills after the checks: the error names result.nc (it said only "No space
    left on device": the write and the fsync know a descriptor, not a name)."""
    def no_space(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", no_space)
    out = tmp_path / "o"
    assert cli.main(["run", str(scene_file), "--out", str(out), "--no-figures"]) == 2
    _one_line_error(capsys, str(out / "result.nc") + ": ", os.strerror(errno.ENOSPC))


def test_a_full_disk_while_writing_the_table_names_it(scene_file, tmp_path, monkeypatch,
                                                      capsys):
    """result.csv is written atomically too: a failure names it (pandas' write error named
    no file) and leaves no torn table."""
    import pandas

    def no_space(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(pandas.DataFrame, "to_csv", no_space)
    out = tmp_path / "o"
    assert cli.main(["run", str(scene_file), "--out", str(out), "--no-figures"]) == 2
    _one_line_error(capsys, str(out / "result.csv") + ": ", os.strerror(errno.ENOSPC))
    assert sorted(p.name for p in out.iterdir()) == [".crandall-files.json", "result.nc"]


@pytest.mark.parametrize("where, words", [
    ("", ["checkpoint must be a file path"]),
    ("missing/run.ckpt", ["checkpoint:", "does not exist"]),
    ("afile", ["checkpoint:", "afile is not a crandall checkpoint"]),
    ("adir", ["checkpoint:", "is a folder"]),
])
def test_bad_checkpoint_exits_2_before_the_run(scene_file, tmp_path, monkeypatch, capsys, where,
                                               words):
    (tmp_path / "afile").write_bytes(b"\x00garbage")
    (tmp_path / "adir").mkdir()
    monkeypatch.chdir(tmp_path)
    calls = []
    monkeypatch.setattr(crandall._core, "run_chunk", lambda *a: calls.append(a))
    assert cli.main(["run", str(scene_file), "--no-files", "--checkpoint", where]) == 2
    _one_line_error(capsys, *words)
    assert calls == []


def test_damaged_checkpoint_from_the_shell_is_one_line(scene_file, tmp_path):
    ckpt = tmp_path / "run.ckpt"
    ckpt.write_bytes(b"PK\x03\x04 truncated")
    proc = crandall_cmd("run", str(scene_file), "--no-files", "--checkpoint", str(ckpt))
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and proc.stderr.count("\n") == 1
    assert proc.stderr.startswith(f"crandall: error: checkpoint: {ckpt} ")


@pytest.mark.parametrize("args, words", [
    (["run", "{binary}"], ["binary.toml: not a text (UTF-8) file"]),
    (["analytic", "{binary}"], ["binary.toml: not a text (UTF-8) file"]),
    (["run", "{small}", "--paths", str(2**64)], ["--paths", "2**64"]),
    (["run", "{small}", "--seed", str(2**64)], ["--seed", "2**64"]),
])
def test_bad_input_exits_2_with_a_message(tmp_path, monkeypatch, capsys, args, words):
    (tmp_path / "binary.toml").write_bytes(b"\x00\xff\xfe not text")
    (tmp_path / "small.toml").write_text(SMALL)
    _no_simulation(monkeypatch)
    args = [a.format(binary=tmp_path / "binary.toml", small=tmp_path / "small.toml")
            for a in args]
    try:
        status = cli.main(args)
    except SystemExit as exc:  # argparse's way of refusing an option
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    for word in words:
        assert word in err


def test_malformed_scheduler_address_exits_2(scene_file, monkeypatch, capsys):
    distributed = pytest.importorskip("distributed")

    def client(address, **kwargs):
        # What distributed.Client("nonsense") raises. A real attempt starts Dask's IO loop in
        # this process, after which the LocalCluster of test_distributed failed to start.
        raise ValueError(f"missing port number in address {address!r}")

    monkeypatch.setattr(distributed, "Client", client)
    assert cli.main(["run", str(scene_file), "--no-files", "--scheduler", "nonsense"]) == 2
    _one_line_error(capsys, "--scheduler", "nonsense")


def test_figures_in_another_format_resolution_and_units(tmp_path, capsys):
    out = tmp_path / "out"
    scene = SCENES / "crate.toml"
    assert cli.main(["run", str(scene), "--paths", "500", "--out", str(out), "--format", "svg",
                     "--dpi", "80"]) == 0
    svgs = sorted(p.name for p in out.glob("*.svg"))
    assert "fig2_distance_mean.svg" in svgs and not list(out.glob("*.png"))
    # A second run in scaled units replaces them (the manifest lists every format).
    assert cli.main(["run", str(scene), "--paths", "500", "--out", str(out), "--overwrite",
                     "--units", "scaled"]) == 0
    assert not list(out.glob("*.svg")) and (out / "fig2_distance_mean.png").exists()
    assert cli.main(["run", str(scene), "--paths", "500", "--no-files", "--dpi", "5"]) == 2
    assert "--dpi must be between 50 and 1200" in capsys.readouterr().err


def test_tail_command_prints_writes_and_draws_the_curve(tmp_path, capsys):
    out = tmp_path / "tail"
    args = ["tail", str(SCENES / "crate.toml"), "--quantity", "residual_displacement",
            "--levels", "0.3", "0.6", "--seed", "3", "--rel-error", "0.3", "--mc-paths", "5000",
            "--out", str(out), "--no-progress"]
    assert cli.main(args) == 0
    captured = capsys.readouterr()
    text = captured.out
    assert "P(residual_displacement > level): splitting" in text and "level [m]" in text
    # The file's [run] table (crandall run's defaults) is said unused, not silently dropped.
    assert (f"crandall: note: {SCENES / 'crate.toml'}: [run] paths = 200000, seed = 7 not "
            "used" in captured.err)
    rows = (out / "tail.csv").read_text().splitlines()
    assert rows[0] == "level,units,probability,stderr,rel_error,lower_95,upper_95,reliable"
    # The curve starts at plain Monte Carlo's 10 % quantile and holds the asked levels.
    levels = [float(r.split(",")[0]) for r in rows[1:]]
    assert 0.3 in levels and 0.6 in levels and len(levels) > 10
    assert (out / "tail.png").stat().st_size > 0
    if importlib.util.find_spec("xarray") is not None:
        saved = crandall.load(out / "tail.nc")   # the result itself, every number as printed
        assert isinstance(saved, crandall.TailResult) and 0.3 in saved.levels
        assert [float(r.split(",")[2]) for r in rows[1:]] == saved.probability.tolist()
    # A second run into the same folder: refused, then replaced with --overwrite.
    assert cli.main(args) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert cli.main(args + ["--overwrite"]) == 0


def test_run_and_tail_keep_to_their_own_files(scene_file, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    # Their own default folders.
    assert cli.main(["run", str(scene_file), "--paths", "500", "--no-figures"]) == 0
    tail = ["tail", str(scene_file), "--quantity", "stop_time", "--levels", "2.0", "--seed", "1",
            "--rel-error", "0.5", "--mc-paths", "500", "--no-progress"]
    assert cli.main(tail) == 0
    assert sorted(p.name for p in (tmp_path / cli.DEFAULT_OUT).iterdir()) == [
        cli.MANIFEST, "result.csv", "result.nc"]
    assert (tmp_path / cli.DEFAULT_TAIL_OUT / "tail.csv").exists()
    # One folder for both: neither is refused for the other's files, and neither's
    # --overwrite removes them.
    shared = ["--out", str(tmp_path / "shared")]
    assert cli.main(["run", str(scene_file), "--paths", "500", "--no-figures"] + shared) == 0
    assert cli.main(tail + shared) == 0
    assert cli.main(tail + shared + ["--overwrite"]) == 0
    assert (tmp_path / "shared" / "result.nc").exists()
    assert (tmp_path / "shared" / "result.csv").exists()
    assert cli.main(["run", str(scene_file), "--paths", "500", "--no-figures", "--overwrite"]
                    + shared) == 0
    assert (tmp_path / "shared" / "tail.csv").exists()
    capsys.readouterr()


def test_tail_command_refuses_bad_options(capsys):
    assert cli.main(["tail", "--quantity", "height", "--levels", "1", "--no-files"]) == 2
    assert "quantity" in capsys.readouterr().err
    assert cli.main(["tail", "--quantity", "speed", "--levels", "1", "--no-files"]) == 2
    assert "time" in capsys.readouterr().err


def test_run_to_an_accuracy_drops_the_distributions_with_a_note_and_takes_statistics(
        tmp_path, capsys):
    scene = tmp_path / "d.toml"
    scene.write_text('[scene]\nunits = "scaled"\ntau0 = 1.0\ntimes = [0.5, 2.0]\n'
                     'distributions = ["distance_at_stop"]\n')
    args = ["run", str(scene), "--rel-error", "0.05", "--seed", "2", "--no-files"]
    assert cli.main(args + ["--statistics", "distance:mean", "distance_at_stop:var"]) == 0
    captured = capsys.readouterr()
    assert "distributions (distance_at_stop) are left out" in captured.err
    # Only the asked statistics carry the target: the others are reported, not driven.
    assert "rel_error <= 0.05" in captured.out and "distance_at_stop" in captured.out
    assert cli.main(args + ["--statistics", "height:mean"]) == 2
    assert "statistics" in capsys.readouterr().err
    assert cli.main(["run", str(scene), "--paths", "100", "--statistics", "distance:mean",
                     "--no-files"]) == 2
    assert "--statistics: only with --error or --rel-error" in capsys.readouterr().err


def test_tail_command_refuses_an_unreachable_target_and_a_failed_estimate(capsys):
    # Each printed a traceback and exited with 1.
    base = ["tail", "--quantity", "stop_time", "--seed", "1", "--threads", "1", "--no-files",
            "--no-progress"]
    assert cli.main(base + ["--levels", "9", "--rel-error", "1e-300"]) == 2
    assert "crandall: error: rel_error must be in [1e-06, 1)" in capsys.readouterr().err
    # No importance-sampling proposal reaches a stop at 1000 (P far below 1e-100): the
    # estimator's StatisticsFailure, said as the other refusals are.
    assert cli.main(base + ["--levels", "1000", "--method", "importance"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("crandall: error: importance sampling: no proposal reached level "
                          "1000"), err
    assert "Traceback" not in err


def test_tail_help_shows_its_percent_sign_once(capsys):
    with pytest.raises(SystemExit):
        cli.main(["tail", "--help"])
    text = " ".join(capsys.readouterr().out.split())  # the lines as wrapped, joined
    assert "95 % band" in text and "%%" not in text


@pytest.mark.parametrize("name", sorted(p.stem for p in SCENES.glob("*.toml")))
def test_every_shipped_scene_runs_to_a_relative_accuracy(name, tmp_path, monkeypatch, capsys):
    # Issue 31's first hour: every shipped scene through `crandall run NAME --rel-error 3e-2`
    # (the distributions dropped with a note; a variance where almost every path is at rest
    # measured against 1 % of its largest value over the times, adaptive.REL_FLOOR; an
    # envelope's pieces refined until their error is within half the target).
    # The file's [run] paths (and vibrating_table's dt) are not refused but said unused.
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", name, "--rel-error", "3e-2", "--no-files"]) == 0
    captured = capsys.readouterr()
    out = captured.out
    assert "levels" in out and "path-steps" in out, out
    run = crandall.Scene.from_toml(name).run_settings
    assert "paths" in run and f"[run] paths = {run['paths']}" in captured.err
    assert ("dt" in run) == ("dt = " in captured.err)
    assert f"seed {run['seed']})" in out


def test_run_to_an_accuracy_refuses_or_notes_the_files_run_fields(tmp_path, capsys):
    # A file's [run] method or event_depth (how each path is computed: the levels keep their
    # own) is refused naming the field, before anything is written; its paths and dt (the
    # size of a fixed-step run, which a target replaces) are said unused; its seed is used.
    f = tmp_path / "r.toml"
    head = '[scene]\nunits = "scaled"\ntau0 = 1.0\ntimes = [0.5, 2.0]\n[run]\nseed = 5\n'
    for line, field in (('method = "exact"', "[run] method = 'exact'"),
                        ("event_depth = 4", "[run] event_depth = 4")):
        f.write_text(head + line + "\n")
        assert cli.main(["run", str(f), "--rel-error", "0.05", "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"crandall: error: {f}: {field}: not with --error"), err
        assert "remove it from the file's [run] table" in err
        assert not (tmp_path / "o").exists()
    f.write_text(head + "paths = 3000\ndt = 0.05\n")
    assert cli.main(["run", str(f), "--rel-error", "0.05", "--statistics", "distance:mean",
                     "--no-files"]) == 0
    captured = capsys.readouterr()
    assert f"crandall: note: {f}: [run] paths = 3000 and dt = 0.05 not used" in captured.err
    assert "seed 5)" in captured.out

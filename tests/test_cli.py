"""The command line: crandall run / analytic, --help, errors, outputs, python -m crandall."""

import importlib.metadata
import pathlib
import re
import runpy
import subprocess
import sys

import numpy as np
import pytest

import crandall
from crandall import analytic, cli
from conftest import same_result

SCENES = pathlib.Path(__file__).resolve().parent.parent / "scenes"
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


def crandall_cmd(*args, cwd=None, timeout=120):
    return subprocess.run([sys.executable, "-m", "crandall", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd)


def test_console_script_is_declared():
    eps = importlib.metadata.entry_points(group="console_scripts")
    assert any(ep.name == "crandall" and ep.value == "crandall.cli:main" for ep in eps)


@pytest.mark.parametrize("args", [["--help"], ["run", "--help"], ["analytic", "--help"]])
def test_help_everywhere(args):
    proc = crandall_cmd(*args)
    assert proc.returncode == 0, proc.stderr
    assert "usage: crandall" in proc.stdout
    if args[0] == "run":
        for option in ("--paths", "--seed", "--threads", "--dt", "--method", "--out",
                       "--checkpoint", "--scheduler"):
            assert option in proc.stdout


def test_run_scene_file_prints_and_writes_everything(tmp_path):
    scene_file = tmp_path / "small.toml"
    scene_file.write_text(SMALL)
    out = tmp_path / "out"
    proc = crandall_cmd("run", str(scene_file), "--out", str(out), "--threads", "1")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""  # no progress bar off a terminal
    direct = crandall.simulate(crandall.Scene.from_toml(scene_file), paths=3000, seed=12,
                               dt=0.05)
    assert direct.summary() in proc.stdout
    files = sorted(p.name for p in out.iterdir())
    assert files == sorted(["result.nc", "result.csv", "fig2_distance_mean.png",
                            "fig3_velocity_var.png", "fig4_displacement_var.png",
                            "fig5_distance_var.png", "velocity_density.png",
                            "stop_time_density.png"])
    assert same_result(crandall.load(out / "result.nc"), direct)
    csv = (out / "result.csv").read_text().splitlines()
    assert csv[0] == "quantity,tau,units,mean,var,std,stderr,var_stderr"
    assert len(csv) == 1 + 5 * 4 + 4
    for png in out.glob("*.png"):
        assert png.stat().st_size > 10_000


def test_options_override_the_file(tmp_path, capsys):
    scene_file = tmp_path / "small.toml"
    scene_file.write_text(SMALL)
    assert cli.main(["run", str(scene_file), "--paths", "2000", "--seed", "4", "--dt", "0.1",
                     "--method", "euler", "--no-files"]) == 0
    out = capsys.readouterr().out
    direct = crandall.simulate(crandall.Scene.from_toml(scene_file), paths=2000, seed=4,
                               dt=0.1, method="euler")
    assert direct.summary() in out
    assert not (tmp_path / cli.DEFAULT_OUT).exists()


def test_checkpoint_option_resumes(tmp_path, capsys):
    scene_file = tmp_path / "small.toml"
    scene_file.write_text(SMALL)
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
    assert re.search(r"\n\s+2\s+0\.49920073\s+0\.0031970974\s+\(noise off\)", out)
    assert cli.main(["analytic", str(SCENES / "crate.toml")]) == 0
    out = capsys.readouterr().out
    expected = analytic.physical("distance_mean", 1.0, mu=0.3, h=1.0, t0=2.0)
    assert f"{expected:.8g}" in out and "[m]" in out
    assert cli.main(["analytic", str(SCENES / "crate.toml"), "--tau0", "1"]) == 2

"""The command line refuses what it would silently ignore: an option beside the flag that makes
it have no effect (--no-files, --no-figures, --hazard-use without --hazard, --mc-paths where
the tail curve has no plain Monte Carlo part), and a scene file's [run] field the scene cannot
run with, each named before anything is printed."""

import importlib

import pytest

import crandall
from crandall import cli

WHITE = '[scene]\nunits = "scaled"\ntau0 = 1.0\ntimes = [0.5, 2.0]\n[run]\npaths = 500\nseed = 1\n'
FILTERED = ('[scene]\nunits = "SI"\nmu = 0.3\nt0 = 1.0\ntimes = [0.5, 2.0]\n'
            "excitation = { kind = 'kanai_tajimi', omega = 2.0, zeta = 0.6, h = 1.0 }\n"
            "[run]\npaths = 500\nseed = 1\n")


@pytest.fixture
def refused(tmp_path, monkeypatch, capsys):
    """Run the command line (in tmp_path) on args that must be refused: exit status 2, one
    line on stderr holding every word given, nothing on stdout, no simulation or tail run
    started and no file or folder made."""
    monkeypatch.chdir(tmp_path)
    def boom(*args, **kwargs):
        raise AssertionError("ran although the command was refused")
    for module, name in (("simulation", "simulate"), ("commands", "simulate"),
                         ("commands", "tail"), ("commands", "fragility")):
        monkeypatch.setattr(importlib.import_module(f"crandall.cli.{module}"), name, boom)

    def check(args, *words):
        capsys.readouterr()
        before = sorted(tmp_path.iterdir())
        assert cli.main([str(a) for a in args]) == 2
        assert sorted(tmp_path.iterdir()) == before
        captured = capsys.readouterr()
        assert captured.out == "", captured.out  # not even the scene or "simulating ..."
        err = captured.err
        assert err.startswith("crandall: error: ") and err.count("\n") == 1, err
        for word in words:
            assert word in err, err
        return err
    return check


@pytest.mark.parametrize("extra, option, flag", [
    (["--no-files", "--out", "o"], "--out", "--no-files"),
    (["--no-files", "--overwrite"], "--overwrite (--force)", "--no-files"),
    (["--no-files", "--force"], "--overwrite (--force)", "--no-files"),
    (["--no-files", "--format", "svg"], "--format", "--no-files"),
    (["--no-files", "--dpi", "300"], "--dpi", "--no-files"),
    (["--no-files", "--units", "scaled"], "--units", "--no-files"),
    (["--no-figures", "--format", "pdf"], "--format", "--no-figures"),
    (["--no-figures", "--dpi", "300"], "--dpi", "--no-figures"),
    (["--no-figures", "--units", "scene"], "--units", "--no-figures"),  # even the default
])
def test_run_refuses_an_option_its_flag_makes_useless(tmp_path, refused, extra, option, flag):
    scene = tmp_path / "w.toml"
    scene.write_text(WHITE)
    refused(["run", scene, *extra], f"{option} has no effect with {flag}")


def test_tail_and_fragility_refuse_the_same(refused):
    tail = ["tail", "crate", "--levels", "1", "--seed", "1"]
    for extra, option in ((["--out", "o"], "--out"), (["--force"], "--overwrite (--force)"),
                          (["--format", "svg"], "--format"), (["--dpi", "100"], "--dpi"),
                          (["--mc-paths", "0"], "--mc-paths")):
        refused(tail + ["--quantity", "stop_time", "--no-files"] + extra,
                f"{option} has no effect with --no-files")
    # The curve of the velocity has no plain Monte Carlo part, with files or without.
    refused(tail + ["--quantity", "velocity", "--time", "1", "--mc-paths", "100"],
            "--mc-paths has no effect with --quantity velocity", "stop_time")
    refused(["fragility", "crate", "--quantity", "stop_time", "--thresholds", "2.5",
             "--intensities", "1.5,2", "--hazard-use", "estimates"],
            "--hazard-use has no effect without --hazard")


def test_run_from_python_refuses_the_same(tmp_path, monkeypatch):
    # crandall.cli.run, called from Python with what the parser refuses beside --no-files or
    # --no-figures, names the argument before loading anything; defaults given pass.
    monkeypatch.chdir(tmp_path)
    from crandall.cli import simulation
    monkeypatch.setattr(simulation, "simulate", lambda *a, **k: (_ for _ in ()).throw(
        AssertionError("ran although refused")))
    scene = tmp_path / "w.toml"
    scene.write_text(WHITE)
    for kw, name in ((dict(files=False, out="o"), "out"),
                     (dict(files=False, overwrite=True), "overwrite"),
                     (dict(files=False, figure_options={"dpi": 300}), "figure_options"),
                     (dict(figures=False, figure_options={"format": "svg"}), "figure_options")):
        with pytest.raises(crandall.ParameterError, match=f"^{name}: ") as info:
            cli.run(str(scene), threads=1, **kw)
        assert info.value.name == name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w.toml"]
    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    assert cli.run(str(scene), threads=1, files=False,
                   figure_options={"format": "png", "dpi": 150, "units": "scene"}) == 0


def test_the_allowed_combinations_still_run(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "w.toml"
    scene.write_text(WHITE)
    # --no-figures with where and how to write the results: used.
    args = ["run", str(scene), "--no-figures", "--out", "o", "--overwrite", "--threads", "1"]
    assert cli.main(args) == 0
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == sorted(
        [cli.MANIFEST, "result.csv", "result.nc"])
    # --no-files with print-side options (--no-figures says no more than --no-files does).
    capsys.readouterr()
    assert cli.main(["run", str(scene), "--no-files", "--no-figures", "--threads", "1"]) == 0
    assert "500 paths" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o", "w.toml"]


def test_a_files_run_field_the_scene_cannot_run_with_is_named_before_any_output(tmp_path,
                                                                                 refused):
    white, filtered = tmp_path / "w.toml", tmp_path / "f.toml"
    white.write_text(WHITE + "event_depth = 4\n")
    refused(["run", white, "--no-files"],
            f"{white}: [run] event_depth = 4: only a filtered excitation",
            "remove it from the file's [run] table")
    refused(["run", white, "--no-files", "--event-depth", "5"], "--event-depth: only a filtered")
    filtered.write_text(FILTERED + 'method = "richardson"\n')
    refused(["run", filtered, "--no-files"],
            f"{filtered}: [run] method = 'richardson': 'richardson' rests on the white-noise",
            "give --method")
    refused(["run", filtered, "--no-files", "--method", "euler"], "--method: 'euler' rests on")
    white.write_text(WHITE.replace("paths = 500", f"paths = {2**63 + 1}"))
    refused(["run", white, "--no-files"], f"{white}: [run] paths = {2**63 + 1}: must be <=")
    refused(["run", white, "--no-files", "--paths", "0"], "--paths must be >= 1")

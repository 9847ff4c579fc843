"""Checkpoints: resume bitwise, refuse another run's file, survive SIGKILL at any moment."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import crandall
from crandall import _core
from conftest import same_result

SIM = sys.modules["crandall.simulate"]
CHUNK = _core.CHUNK_PATHS
REAL_RUN_CHUNK = _core.run_chunk
PATHS = 4 * CHUNK + 1000  # five chunks, the last one short


def scene():
    return crandall.Scene.scaled(tau0=1.0, times=[0.25, 0.5, 1.0, 1.5])


class Stop(Exception):
    """Stands for whatever ends a run early (Ctrl-C, a crash)."""


def counting_run_chunk(monkeypatch, fail_at=None):
    """Replace the core's chunk runner by one that counts calls and can fail at a chunk."""
    calls = []
    real = REAL_RUN_CHUNK

    def run_chunk(plan, chunk, threads):
        if chunk == fail_at:
            raise Stop
        calls.append(chunk)
        return real(plan, chunk, threads)

    monkeypatch.setattr(SIM._core, "run_chunk", run_chunk)
    return calls


def test_checkpoint_does_not_change_the_result(tmp_path):
    plain = crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05)
    kept = crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, checkpoint=tmp_path / "c")
    assert same_result(plain, kept)
    assert os.path.exists(tmp_path / "c")
    assert [p.name for p in tmp_path.iterdir()] == ["c"]  # no temporary files left


def test_resume_after_interrupt_is_bitwise_identical(tmp_path, monkeypatch):
    path = tmp_path / "run.ckpt"
    plain = crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05)
    counting_run_chunk(monkeypatch, fail_at=3)
    with pytest.raises(Stop):
        crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, checkpoint=path)
    calls = counting_run_chunk(monkeypatch)
    resumed = crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, checkpoint=path)
    assert calls == [3, 4]  # chunks 0-2 came from the file
    assert same_result(plain, resumed)
    assert resumed.seed == 5 and resumed.paths == PATHS


def test_seed_none_takes_the_checkpoints_seed(tmp_path, monkeypatch):
    path = tmp_path / "run.ckpt"
    counting_run_chunk(monkeypatch, fail_at=2)
    with pytest.raises(Stop):
        crandall.simulate(scene(), paths=PATHS, seed=77, dt=0.05, checkpoint=path)
    monkeypatch.undo()
    resumed = crandall.simulate(scene(), paths=PATHS, dt=0.05, checkpoint=path)
    assert resumed.seed == 77
    assert same_result(resumed, crandall.simulate(scene(), paths=PATHS, seed=77, dt=0.05))


def test_complete_checkpoint_returns_without_simulating(tmp_path, monkeypatch):
    path = tmp_path / "run.ckpt"
    first = crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, checkpoint=path)
    calls = counting_run_chunk(monkeypatch)
    again = crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, checkpoint=path)
    assert calls == []
    assert same_result(first, again)


def sweep():
    return [crandall.Scene.scaled(tau0=t, times=[0.25, 0.5]) for t in (0.5, 1.0, 1.5)]


def test_sweep_resumes_every_scene_bitwise(tmp_path, monkeypatch):
    folder = tmp_path / "sweep"
    plain = crandall.simulate_many(sweep(), paths=PATHS, seed=9, dt=0.05)
    # Stop in the second scene's fourth chunk: scene 0 is complete, scene 1 has 3 chunks.
    calls = []

    def run_chunk(plan, chunk, threads):
        if len(calls) == 5 + 3:
            raise Stop
        calls.append(chunk)
        return REAL_RUN_CHUNK(plan, chunk, threads)

    monkeypatch.setattr(SIM._core, "run_chunk", run_chunk)
    with pytest.raises(Stop):
        crandall.simulate_many(sweep(), paths=PATHS, seed=9, dt=0.05, checkpoint_dir=folder)
    assert sorted(p.name for p in folder.iterdir()) == ["scene-0000.ckpt", "scene-0001.ckpt"]
    calls = counting_run_chunk(monkeypatch)
    resumed = crandall.simulate_many(sweep(), paths=PATHS, dt=0.05, checkpoint_dir=folder)
    assert calls == [3, 4] + [0, 1, 2, 3, 4]  # scene 0 from its file, scene 1 from chunk 3
    assert all(r.seed == 9 for r in resumed)  # seed=None: taken from the checkpoints
    assert all(same_result(a, b) for a, b in zip(plain, resumed))


def test_sweep_checkpoints_of_another_sweep_are_refused(tmp_path):
    folder = tmp_path / "sweep"
    crandall.simulate_many(sweep(), paths=1000, seed=9, dt=0.05, checkpoint_dir=folder)
    with pytest.raises(ValueError, match="seed"):
        crandall.simulate_many(sweep(), paths=1000, seed=10, dt=0.05, checkpoint_dir=folder)
    with pytest.raises(ValueError, match="scene"):
        crandall.simulate_many(sweep()[::-1], paths=1000, seed=9, dt=0.05, checkpoint_dir=folder)


def test_sweep_checkpoint_dir_must_be_a_directory(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(ValueError, match="checkpoint_dir"):
        crandall.simulate_many(sweep(), paths=1000, seed=9, checkpoint_dir=f)
    with pytest.raises(ValueError, match="checkpoint_dir"):
        crandall.simulate_many(sweep(), paths=1000, seed=9, checkpoint_dir=3)


@pytest.mark.parametrize("change, word", [
    ({"seed": 6}, "seed"),
    ({"paths": PATHS + 1}, "paths"),
    ({"dt": 0.025}, "dt"),
    ({"method": "euler"}, "method"),
    ({"scene": crandall.Scene.scaled(tau0=2.0, times=[0.25, 0.5, 1.0, 1.5])}, "scene"),
])
def test_checkpoint_of_another_run_is_refused(tmp_path, change, word):
    path = tmp_path / "run.ckpt"
    crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, checkpoint=path)
    before = path.read_bytes()
    kwargs = {"scene": scene(), "paths": PATHS, "seed": 5, "dt": 0.05}
    kwargs.update(change)
    sc = kwargs.pop("scene")
    with pytest.raises(ValueError, match=f"checkpoint: .*different run.*{word}"):
        crandall.simulate(sc, checkpoint=path, **kwargs)
    assert path.read_bytes() == before  # untouched


def test_a_file_that_is_not_a_checkpoint_is_refused(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("not a checkpoint")
    with pytest.raises(ValueError, match="not a crandall checkpoint"):
        crandall.simulate(scene(), paths=10, seed=1, checkpoint=path)
    with pytest.raises(ValueError, match="checkpoint must be a path"):
        crandall.simulate(scene(), paths=10, seed=1, checkpoint=3)


KILLED = textwrap.dedent(
    """
    import sys, crandall
    scene = crandall.Scene.scaled(tau0=1.0, times=[0.25, 0.5, 1.0, 1.5])
    print("started", flush=True)
    crandall.simulate(scene, paths=int(sys.argv[2]), seed=11, dt=0.01, threads=2,
                      checkpoint=sys.argv[1])
    print("finished", flush=True)
    """
)


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs POSIX signals")
def test_sigkill_mid_run_then_resume_is_bitwise_identical(tmp_path):
    path = tmp_path / "killed.ckpt"
    paths = 7 * CHUNK + 123  # eight chunks
    proc = subprocess.Popen([sys.executable, "-c", KILLED, str(path), str(paths)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "started"
        # Kill just after the first checkpoint lands: a chunk done, the next one in flight.
        deadline = time.monotonic() + 60
        writes, last = 0, None
        while writes < 1 and time.monotonic() < deadline and proc.poll() is None:
            if path.exists():
                stamp = path.stat().st_mtime_ns
                if stamp != last:
                    writes, last = writes + 1, stamp
            time.sleep(0.01)
        time.sleep(0.05)
        assert proc.poll() is None, "the run ended before it could be killed"
        proc.send_signal(signal.SIGKILL)
        proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    with np.load(path, allow_pickle=False) as data:
        done = int(data["next_chunk"])
    assert 1 <= done < 8, done  # some finished chunks kept, the run not over
    resumed = crandall.simulate(scene(), paths=paths, seed=11, dt=0.01, threads=2,
                                checkpoint=path)
    plain = crandall.simulate(scene(), paths=paths, seed=11, dt=0.01, threads=1)
    assert same_result(plain, resumed)
    np.testing.assert_array_equal(plain.moment(1, 1, 2), resumed.moment(1, 1, 2))


def test_progress_bar_when_asked_and_not_under_pytest(capsys):
    crandall.simulate(scene(), paths=2 * CHUNK, seed=1, dt=0.25, progress=True)
    err = capsys.readouterr().err
    assert "crandall" in err and "path" in err
    crandall.simulate(scene(), paths=2 * CHUNK, seed=1, dt=0.25)
    assert capsys.readouterr().err == ""
    with pytest.raises(ValueError, match="progress"):
        crandall.simulate(scene(), paths=10, seed=1, progress="yes")

"""Checkpoints: resume bitwise, refuse another run's file, survive SIGKILL at any moment."""

import errno
import json
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


class Interrupted(Exception):
    """Stands for whatever ends a run early (Ctrl-C, a crash)."""


def counting_run_chunk(monkeypatch, fail_at=None):
    """Replace the core's chunk runner by one that counts calls and can fail at a chunk."""
    calls = []
    real = REAL_RUN_CHUNK

    def run_chunk(plan, chunk, threads):
        if chunk == fail_at:
            raise Interrupted
        calls.append(chunk)
        return real(plan, chunk, threads)

    monkeypatch.setattr(_core, "run_chunk", run_chunk)
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
    with pytest.raises(Interrupted):
        crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, checkpoint=path)
    calls = counting_run_chunk(monkeypatch)
    resumed = crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, checkpoint=path)
    assert calls == [3, 4]  # chunks 0-2 came from the file
    assert same_result(plain, resumed)
    assert resumed.seed == 5 and resumed.paths == PATHS


def test_seed_none_takes_the_checkpoints_seed(tmp_path, monkeypatch):
    path = tmp_path / "run.ckpt"
    counting_run_chunk(monkeypatch, fail_at=2)
    with pytest.raises(Interrupted):
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
    # Interrupt in the second scene's fourth chunk: scene 0 is complete, scene 1 has 3 chunks.
    calls = []

    def run_chunk(plan, chunk, threads):
        if len(calls) == 5 + 3:
            raise Interrupted
        calls.append(chunk)
        return REAL_RUN_CHUNK(plan, chunk, threads)

    monkeypatch.setattr(_core, "run_chunk", run_chunk)
    with pytest.raises(Interrupted):
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


# -- damaged, edited and misplaced checkpoints ----------------------------------------------

CKPT_FIELDS = ("identity", "next_chunk", "times_counts", "times_means", "times_central",
               "stop_counts", "stop_means", "stop_central")
IDENTITY_FIELDS = ("format_version", "crandall", "scene", "paths", "seed", "dt", "method")


@pytest.fixture(scope="module")
def partial_checkpoint(tmp_path_factory):
    """A checkpoint of chunks 0-1 of a five-chunk run (method "exact": plain sums, so even
    central sums are sums of squares), as raw bytes and as its arrays."""
    path = tmp_path_factory.mktemp("ckpt") / "run.ckpt"
    with pytest.MonkeyPatch.context() as mp:
        counting_run_chunk(mp, fail_at=2)
        with pytest.raises(Interrupted):
            crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, method="exact",
                              checkpoint=path)
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    assert int(arrays["next_chunk"]) == 2
    return path.read_bytes(), arrays


def _identity(arrays):
    return json.loads(str(arrays["identity"]))


def _with_identity(arrays, **change):
    ident = _identity(arrays)
    for key, value in change.items():
        if value is _MISSING:
            del ident[key]
        else:
            ident[key] = value
    return {**arrays, "identity": np.array(json.dumps(ident))}


_MISSING = object()


def _without(arrays, key):
    return {k: v for k, v in arrays.items() if k != key}


def _edit(arrays, key, fn):
    a = arrays[key].copy()
    out = fn(a)
    return {**arrays, key: a if out is None else out}


def _set(index, value):
    def fn(a):
        a[index] = value
    return fn


# Each case: (id, how to damage (bytes, arrays) -> bytes or dict of arrays, what the message
# must name).
CORRUPTIONS = [
    ("truncated-half", lambda b, a: b[: len(b) // 2], "truncated"),
    ("truncated-20-bytes", lambda b, a: b[:20], "truncated"),
    ("empty", lambda b, a: b"", "truncated"),
    ("random-bytes", lambda b, a: np.random.default_rng(1).bytes(4000), "npz archive"),
    ("text", lambda b, a: b"not a checkpoint", "npz archive"),
    ("npy", lambda b, a: "npy", "npz archive"),
    ("identity-not-json", lambda b, a: {**a, "identity": np.array("{seed: 5")}, "identity"),
    ("identity-a-number", lambda b, a: {**a, "identity": np.array(5.0)}, "identity"),
    ("identity-a-list", lambda b, a: {**a, "identity": np.array("[1, 2]")}, "identity"),
    ("identity-other-format", lambda b, a: _with_identity(a, format="other"), "identity.format"),
    ("identity-extra-field", lambda b, a: _with_identity(a, extra=1), "extra"),
    ("extra-array", lambda b, a: {**a, "more": np.zeros(3)}, "more"),
    ("next_chunk-past-the-end", lambda b, a: {**a, "next_chunk": np.array(99)}, "next_chunk"),
    ("next_chunk-negative", lambda b, a: {**a, "next_chunk": np.array(-1)}, "next_chunk"),
    ("next_chunk-float", lambda b, a: {**a, "next_chunk": np.array(2.0)}, "next_chunk"),
    ("next_chunk-array", lambda b, a: {**a, "next_chunk": np.array([2, 3])}, "next_chunk"),
    ("next_chunk-text", lambda b, a: {**a, "next_chunk": np.array("2")}, "next_chunk"),
    # In range but not what the accumulators hold: the counts give it away.
    ("next_chunk-tampered", lambda b, a: {**a, "next_chunk": np.array(3)}, "next_chunk is 3"),
    ("next_chunk-zero", lambda b, a: {**a, "next_chunk": np.array(0)}, "next_chunk is 0"),
    ("times_counts-tampered", lambda b, a: _edit(a, "times_counts", _set(1, 5.0)),
     "times_counts"),
    ("stop_counts-tampered", lambda b, a: _edit(a, "stop_counts", lambda x: x + 1),
     "stop_counts"),
    ("times_central-count-column", lambda b, a: _edit(a, "times_central", _set((0, 0), 7.0)),
     "times_central"),
    ("times_central-negative-variance",
     lambda b, a: _edit(a, "times_central", _set((2, 4), -1.0)), "times_central"),
    ("stop_central-negative-fourth-moment",
     lambda b, a: _edit(a, "stop_central", _set((0, 34), -3.0)), "stop_central"),
    ("times_means-nan", lambda b, a: _edit(a, "times_means", _set((1, 2), np.nan)),
     "times_means"),
    ("times_central-inf", lambda b, a: _edit(a, "times_central", _set((3, 9), np.inf)),
     "times_central"),
    ("stop_means-nan", lambda b, a: _edit(a, "stop_means", _set((0, 0), np.nan)), "stop_means"),
    ("times_counts-nan", lambda b, a: _edit(a, "times_counts", _set(0, np.nan)), "times_counts"),
    ("times_counts-short", lambda b, a: _edit(a, "times_counts", lambda x: x[:3]),
     "times_counts"),
    ("times_means-wide", lambda b, a: _edit(a, "times_means", lambda x: np.ones((4, 4))),
     "times_means"),
    ("times_central-narrow", lambda b, a: _edit(a, "times_central", lambda x: x[:, :34]),
     "times_central"),
    ("times_means-flat", lambda b, a: _edit(a, "times_means", lambda x: x.ravel()),
     "times_means"),
    ("stop_counts-two-slots", lambda b, a: _edit(a, "stop_counts", lambda x: np.r_[x, x]),
     "stop_counts"),
    ("stop_central-text", lambda b, a: {**a, "stop_central": np.array(["x"] * 35)},
     "stop_central"),
    ("times_means-bool", lambda b, a: _edit(a, "times_means", lambda x: x > 0), "times_means"),
]
CORRUPTIONS += [(f"missing-{k}", (lambda k: lambda b, a: _without(a, k))(k), k)
                for k in CKPT_FIELDS]
CORRUPTIONS += [(f"missing-identity.{k}",
                 (lambda k: lambda b, a: _with_identity(a, **{k: _MISSING}))(k),
                 f"identity.{k}") for k in IDENTITY_FIELDS]
CORRUPTIONS += [(f"wrong-type-identity.{k}",
                 (lambda k, v: lambda b, a: _with_identity(a, **{k: v}))(k, v), f"identity.{k}")
                for k, v in [("format_version", "1"), ("crandall", 0.1), ("scene", [1, 2]),
                             ("paths", "327144"), ("paths", 0), ("paths", True),
                             ("seed", "5"), ("seed", -5), ("seed", 1 << 64), ("seed", 5.0),
                             ("dt", "0.05"), ("dt", -0.05), ("dt", None), ("method", 3)]]


def _write_damaged(path, damaged):
    if damaged == "npy":
        with open(path, "wb") as f:
            np.save(f, np.arange(10.0))
    elif isinstance(damaged, bytes):
        path.write_bytes(damaged)
    else:
        with open(path, "wb") as f:
            np.savez(f, **damaged)


@pytest.mark.parametrize("damage, field", [c[1:] for c in CORRUPTIONS],
                         ids=[c[0] for c in CORRUPTIONS])
def test_damaged_checkpoint_is_a_value_error_naming_file_and_field(
        tmp_path, monkeypatch, partial_checkpoint, damage, field):
    raw, arrays = partial_checkpoint
    path = tmp_path / "run.ckpt"
    _write_damaged(path, damage(raw, arrays))
    before = path.read_bytes()
    calls = counting_run_chunk(monkeypatch)
    with pytest.raises(ValueError) as info:
        crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, method="exact",
                          checkpoint=path)
    message = str(info.value)
    assert message.startswith(f"checkpoint: {path} ")
    assert field in message
    assert calls == []  # refused before simulating anything
    assert path.read_bytes() == before  # and left as it was


def test_undamaged_partial_checkpoint_resumes(tmp_path, monkeypatch, partial_checkpoint):
    """The table's starting point is valid: only the damage makes it fail."""
    path = tmp_path / "run.ckpt"
    path.write_bytes(partial_checkpoint[0])
    calls = counting_run_chunk(monkeypatch)
    resumed = crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, method="exact",
                                checkpoint=path)
    assert calls == [2, 3, 4]
    monkeypatch.undo()
    assert same_result(resumed, crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05,
                                                  method="exact"))


@pytest.mark.parametrize("damage", ["missing-identity.seed", "wrong-type-identity.seed",
                                    "random-bytes", "npy", "truncated-half"])
def test_damaged_checkpoint_with_seed_none(tmp_path, partial_checkpoint, damage):
    """seed=None reads the seed from the checkpoint first: the same ValueError."""
    raw, arrays = partial_checkpoint
    fn = next(c[1] for c in CORRUPTIONS if c[0] == damage)
    path = tmp_path / "run.ckpt"
    _write_damaged(path, fn(raw, arrays))
    with pytest.raises(ValueError, match=f"^checkpoint: {path} "):
        crandall.simulate(scene(), paths=PATHS, dt=0.05, method="exact", checkpoint=path)


EVEN = [i for i, e in enumerate(_core.monomial_exponents()) if all(p % 2 == 0 for p in e)]


def test_negative_even_central_sums_are_allowed_where_richardson_makes_them(tmp_path):
    """Richardson extrapolation combines grids with signed weights: for two paths its
    "variance" can come out negative, and such a checkpoint is the run's, not damage. (Two
    paths, not one: with one path every variance is undefined and warns.)"""
    sc = crandall.Scene.scaled(tau0=5, times=[0.5, 1.0, 5.0, 8.0])
    for seed in range(40):
        path = tmp_path / f"r{seed}.ckpt"
        r = crandall.simulate(sc, paths=2, seed=seed, checkpoint=path)
        if (r.accumulators.times.central[:, EVEN] < 0).any():
            break
    else:  # the core no longer extrapolates below zero: nothing to check
        pytest.skip("no negative extrapolated central sum among 40 seeds")
    again = crandall.simulate(sc, paths=2, seed=seed, checkpoint=path)
    assert same_result(r, again)


def _read_only_folders():
    out = []
    out.append(pytest.param("chmod", marks=pytest.mark.skipif(
        os.geteuid() == 0, reason="root writes into read-only folders")))
    writable_sys = os.access("/sys", os.W_OK) and not os.path.ismount("/sys")
    out.append(pytest.param("/sys", marks=pytest.mark.skipif(
        not os.path.isdir("/sys") or writable_sys, reason="needs a read-only /sys")))
    return out


def _read_only(tmp_path, kind):
    if kind == "chmod":
        folder = tmp_path / "ro"
        folder.mkdir()
        folder.chmod(0o500)
        return folder
    import tempfile
    try:  # the mount must really refuse (it does in containers and for non-root users)
        fd, name = tempfile.mkstemp(dir=kind)
    except OSError:
        return kind
    os.close(fd)
    os.unlink(name)
    pytest.skip(f"{kind} is writable here")


@pytest.mark.parametrize("kind", _read_only_folders())
def test_read_only_checkpoint_place_fails_before_the_run(tmp_path, monkeypatch, kind):
    folder = _read_only(tmp_path, kind)
    calls = counting_run_chunk(monkeypatch)
    try:
        with pytest.raises(ValueError, match="^checkpoint: cannot write in"):
            crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05,
                              checkpoint=os.path.join(folder, "run.ckpt"))
        with pytest.raises(ValueError, match="^checkpoint_dir: cannot write in"):
            crandall.simulate_many(sweep(), paths=PATHS, seed=5, dt=0.05,
                                   checkpoint_dir=os.path.join(folder, "sweep"))
        # An existing folder: each scene's checkpoint is checked.
        with pytest.raises(ValueError, match="^checkpoint: cannot write in"):
            crandall.simulate_many(sweep(), paths=PATHS, seed=5, dt=0.05,
                                   checkpoint_dir=folder)
    finally:
        if kind == "chmod":
            os.chmod(folder, 0o700)
    assert calls == []


@pytest.mark.parametrize("where, message", [
    ("", "checkpoint must be a file path"),
    ("   ", "checkpoint must be a file path"),
    ("missing/run.ckpt", "checkpoint: .*does not exist"),
    ("afile/run.ckpt", "checkpoint: .*is not a folder"),
    ("adir", "checkpoint: .*is a folder"),
    ("adir/", "checkpoint: .*is a folder"),
    ("newdir/", "checkpoint: .*names a folder"),
])
def test_bad_checkpoint_path_fails_before_the_run(tmp_path, monkeypatch, where, message):
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    monkeypatch.chdir(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    calls = counting_run_chunk(monkeypatch)
    with pytest.raises(ValueError, match=f"^{message}"):
        crandall.simulate(scene(), paths=PATHS, seed=5, dt=0.05, checkpoint=where)
    assert calls == []
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing left behind


def test_sweep_checkpoint_dir_that_cannot_be_created_fails_before_the_run(tmp_path,
                                                                          monkeypatch):
    (tmp_path / "afile").write_text("x")
    calls = counting_run_chunk(monkeypatch)
    with pytest.raises(ValueError, match="^checkpoint_dir: cannot create"):
        crandall.simulate_many(sweep(), paths=PATHS, seed=5, dt=0.05,
                               checkpoint_dir=tmp_path / "afile" / "sweep")
    with pytest.raises(ValueError, match="^checkpoint_dir must be a folder path"):
        crandall.simulate_many(sweep(), paths=PATHS, seed=5, dt=0.05, checkpoint_dir="")
    assert calls == []
    # A missing folder (and its parents) is made.
    crandall.simulate_many(sweep(), paths=10, seed=5, dt=0.05,
                           checkpoint_dir=tmp_path / "a" / "b")
    assert sorted(p.name for p in (tmp_path / "a" / "b").iterdir()) == [
        "scene-0000.ckpt", "scene-0001.ckpt", "scene-0002.ckpt"]


def test_checking_a_checkpoint_place_creates_nothing(tmp_path):
    from crandall import checkpoint

    assert checkpoint.check_writable(tmp_path / "run.ckpt") == str(tmp_path / "run.ckpt")
    assert list(tmp_path.iterdir()) == []


def test_checkpoint_write_leaves_no_temporary_file_on_failure(tmp_path, monkeypatch):
    """The shared atomic writer removes its temporary file if writing fails midway."""
    from crandall import _files

    path = tmp_path / "f"
    path.write_bytes(b"old")

    def fail(f):
        f.write(b"partial")
        raise Interrupted

    with pytest.raises(Interrupted):
        _files.write_atomic(path, fail)
    assert [p.name for p in tmp_path.iterdir()] == ["f"] and path.read_bytes() == b"old"
    fsyncs = []
    real = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: fsyncs.append(fd) or real(fd))
    _files.write_atomic(path, lambda f: f.write(b"new"))
    assert path.read_bytes() == b"new" and len(fsyncs) == 2  # the file, then its folder


def test_atomic_writes_respect_the_umask(tmp_path):
    """Files written atomically (results, checkpoints, the file list) get the mode open()
    would give, 0666 less the umask: they were 0600 whatever the umask (mkstemp's mode)."""
    from crandall import _files

    old = os.umask(0o022)
    try:
        for mask, mode in ((0o022, 0o644), (0o077, 0o600), (0o002, 0o664)):
            os.umask(mask)
            path = tmp_path / f"f{mask:o}"
            _files.write_atomic(path, lambda f: f.write(b"x"))
            assert path.stat().st_mode & 0o777 == mode, (oct(mask), oct(path.stat().st_mode))
    finally:
        os.umask(old)


def test_atomic_writes_are_never_more_permissive_than_open_would_make_them(tmp_path,
                                                                         monkeypatch):
    """The file gets the mode open() would give (0666 less the umask) and is never more
    permissive on the way, and the process's umask is never changed, even for an instant: it
    was set to 0o022 and back to be read, so a file another thread created meanwhile got 0644
    under a umask of 0o077 (and this one's mode was computed, not the kernel's)."""
    from crandall import _files

    created, masks = [], []
    real_open, real_umask = os.open, os.umask

    def spy_open(path, flags, *args, **kwargs):
        fd = real_open(path, flags, *args, **kwargs)
        if flags & os.O_CREAT:
            created.append(os.fstat(fd).st_mode & 0o777)
        return fd

    def spy_umask(mask):
        masks.append(mask)
        return real_umask(mask)

    old = os.umask(0o022)
    try:
        monkeypatch.setattr(os, "open", spy_open)
        monkeypatch.setattr(os, "umask", spy_umask)
        for mask, mode in ((0o277, 0o400), (0o077, 0o600), (0o027, 0o640), (0o002, 0o664)):
            real_umask(mask)
            created.clear()
            masks.clear()
            path = tmp_path / f"f{mask:o}"
            _files.write_atomic(path, lambda f: f.write(b"x"))
            assert path.stat().st_mode & 0o777 == mode, (oct(mask), oct(path.stat().st_mode))
            assert created and all(m & ~mode == 0 for m in created), (
                oct(mask), [oct(m) for m in created])
            assert all(m == mask for m in masks), (oct(mask), [oct(m) for m in masks])
            assert path.read_bytes() == b"x"
    finally:
        real_umask(old)


def _no_space(*args, **kwargs):
    # What a full disk raises from a write or an fsync: no file name (it has only a descriptor).
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


@pytest.mark.parametrize("where", ["write", "fsync", "replace"])
def test_a_failed_atomic_write_names_the_file(tmp_path, monkeypatch, where):
    """A disk-full error while saving names the file being saved (it named none: the write and
    the fsync know only a descriptor, the rename the temporary file). The old file stays, and
    no temporary file is left."""
    from crandall import _files

    path = tmp_path / "result.nc"
    path.write_bytes(b"old")
    write = lambda f: f.write(b"new")  # noqa: E731
    if where == "write":
        write = _no_space
    elif where == "fsync":
        monkeypatch.setattr(os, "fsync", _no_space)
    else:
        def no_rename(src, dst):
            raise OSError(errno.EIO, os.strerror(errno.EIO), src, dst)
        monkeypatch.setattr(os, "replace", no_rename)
    with pytest.raises(OSError) as info:
        _files.write_atomic(path, write)
    exc = info.value
    assert exc.errno == (errno.EIO if where == "replace" else errno.ENOSPC)
    assert exc.filename == str(path) and str(path) in str(exc), str(exc)
    assert exc.strerror in str(exc)
    assert [p.name for p in tmp_path.iterdir()] == ["result.nc"]
    assert path.read_bytes() == b"old"


def test_a_full_disk_names_the_result_and_the_checkpoint(tmp_path, monkeypatch):
    """Result.save and a checkpoint's write name their file when the disk is full."""
    from crandall import checkpoint

    r = crandall.simulate(scene(), paths=100, seed=1)
    monkeypatch.setattr(os, "fsync", _no_space)
    for path, save in ((tmp_path / "r.nc", r.save),
                       (tmp_path / "run.ckpt", lambda p: checkpoint.write(
                           p, {"format": 1}, {"x": np.zeros(2)}))):
        with pytest.raises(OSError, match="No space left") as info:
            save(path)
        assert info.value.filename == str(path) and str(path) in str(info.value)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("how", [
    pytest.param("chmod", marks=pytest.mark.skipif(
        os.geteuid() == 0, reason="root writes into read-only folders")),
    "refused",  # any user: every attempt to create a file in the folder fails
])
def test_complete_checkpoints_in_a_read_only_folder_are_still_read(tmp_path, monkeypatch, how):
    """A finished run only reads its checkpoint: a read-only place is fine for it."""
    import tempfile

    folder = tmp_path / "done"
    folder.mkdir()
    first = crandall.simulate(scene(), paths=1000, seed=5, dt=0.05,
                              checkpoint=folder / "run.ckpt")
    sweep_first = crandall.simulate_many(sweep(), paths=1000, seed=5, dt=0.05,
                                         checkpoint_dir=folder / "sweep")
    if how == "chmod":
        (folder / "sweep").chmod(0o500)
        folder.chmod(0o500)
    else:
        real = tempfile.mkstemp

        def mkstemp(*args, dir=None, **kwargs):
            if dir is not None and str(dir).startswith(str(folder)):
                raise PermissionError(13, "Permission denied", str(dir))
            return real(*args, dir=dir, **kwargs)

        monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
    calls = counting_run_chunk(monkeypatch)
    try:
        again = crandall.simulate(scene(), paths=1000, seed=5, dt=0.05,
                                  checkpoint=folder / "run.ckpt")
        sweep_again = crandall.simulate_many(sweep(), paths=1000, seed=5, dt=0.05,
                                             checkpoint_dir=folder / "sweep")
        # A run with chunks left in the same place is refused before it starts.
        with pytest.raises(ValueError, match="^checkpoint: cannot write in"):
            crandall.simulate(scene(), paths=1000, seed=5, dt=0.05,
                              checkpoint=folder / "other.ckpt")
    finally:
        if how == "chmod":
            folder.chmod(0o700)
            (folder / "sweep").chmod(0o700)
    assert calls == []
    assert same_result(first, again)
    assert all(same_result(a, b) for a, b in zip(sweep_first, sweep_again))

"""The wheel users install: built by `make wheel` (pip wheel, then auditwheel repair, which
tags it manylinux and vendors libgomp), installed into a fresh virtual environment with only
its declared dependencies, where a small run must give the bits of this source build."""

from __future__ import annotations

import glob
import json
import os
import pathlib
import subprocess
import sys

import pytest

import crandall

ROOT = pathlib.Path(__file__).resolve().parent.parent
RUN = ("import crandall, json; "
       "sc = crandall.Scene.scaled(tau0=2.0, times=[0.5, 2.0], distributions=['stop_time']); "
       "r = crandall.simulate(sc, paths=3000, seed=11, threads=2); "
       "print(json.dumps({n: [float(x).hex() for x in __import__('numpy').atleast_1d(r.var(n))]"
       " for n in r.names} | {'q': float(r.quantile('stop_time', 0.9).value).hex(), "
       "'file': crandall.__file__}))")


def _wheels():
    return sorted(glob.glob(str(ROOT / "dist" / "crandall-*manylinux*_x86_64.whl")))


@pytest.mark.skipif(not _wheels(), reason="no wheel in dist/: make wheel builds it (make test does)")
def test_the_manylinux_wheel_installs_alone_and_gives_the_source_bits(tmp_path):
    wheel = _wheels()[-1]
    assert crandall.__version__ in os.path.basename(wheel)
    # libgomp is inside the wheel (auditwheel vendored it), so a machine without it can run it.
    listing = subprocess.run([sys.executable, "-m", "zipfile", "-l", wheel], capture_output=True,
                             text=True, check=True).stdout
    assert "libgomp" in listing
    env_dir = tmp_path / "venv"
    clean = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    subprocess.run([sys.executable, "-m", "venv", str(env_dir)], check=True, env=clean)
    py = str(env_dir / "bin" / "python")
    subprocess.run([py, "-m", "pip", "install", "-q", wheel], check=True, env=clean,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    # Isolated (-I): the fresh environment's crandall, not this checkout's.
    out = subprocess.run([py, "-I", "-c", RUN], capture_output=True, text=True, check=True,
                         cwd=tmp_path, env=clean).stdout
    theirs = json.loads(out.strip().splitlines()[-1])
    assert str(env_dir) in theirs.pop("file")
    ours = json.loads(subprocess.run([sys.executable, "-c", RUN], capture_output=True,
                                     text=True, check=True).stdout.strip().splitlines()[-1])
    ours.pop("file")
    assert theirs == ours
    # The shipped scenes are package data: read by name in an empty folder.
    assert "crandall/scenes/crate.toml" in listing
    out = subprocess.run([py, "-I", "-c", "import crandall; print(crandall.Scene.from_toml("
                          "'crate').run_settings, len(crandall.Scene.shipped()))"],
                         capture_output=True, text=True, check=True, cwd=tmp_path, env=clean)
    assert out.stdout.split() == ["{'paths':", "200000,", "'seed':", "7}", "6"]

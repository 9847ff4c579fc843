"""The same seed gives the same bits whatever kernel variant runs (docs/random-numbers.md):
every variant this host supports, forced with CRANDALL_ISA in a subprocess; the package built as
a wheel and run on an emulated CPU without AVX (qemu-user); a Dask cluster whose two workers run
different variants."""

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import crandall
from crandall import _core
from conftest import same_result

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PROBE = HERE / "isa_probe.py"
AVAILABLE = _core.build_info()["isa_available"]
BEST = AVAILABLE[-1]


def run_probe(isa=None, prefix=(), pythonpath=None, timeout=600):
    env = dict(os.environ)
    env.pop("CRANDALL_ISA", None)
    if isa is not None:
        env["CRANDALL_ISA"] = isa
    if pythonpath is not None:
        env["PYTHONPATH"] = os.pathsep.join(pythonpath)
    else:
        # the crandall under test, wherever it is imported from
        env["PYTHONPATH"] = os.pathsep.join([str(Path(crandall.__file__).parent.parent)]
                                            + env.get("PYTHONPATH", "").split(os.pathsep))
    out = subprocess.run([*prefix, sys.executable, str(PROBE)], env=env, capture_output=True,
                         text=True, timeout=timeout)
    return out


@pytest.fixture(scope="module")
def native():
    out = run_probe()
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_default_is_the_best_variant_and_every_variant_gives_the_same_bits(native):
    assert native["isa"] == BEST
    assert len(native["stats"]) == 30  # 5 methods x (5 observable sets and a scene with pauses)
    for isa in AVAILABLE:
        out = run_probe(isa)
        assert out.returncode == 0, out.stderr
        got = json.loads(out.stdout)
        assert got["isa"] == isa
        for key, stats in native["stats"].items():
            assert got["stats"][key] == stats, (isa, key)
        assert got["newmark"] == native["newmark"], isa
        assert got["split"] == native["split"], isa


def test_unknown_variant_is_refused_at_import():
    out = run_probe("avx1024")
    assert out.returncode != 0
    assert "ImportError" in out.stderr and "CRANDALL_ISA='avx1024'" in out.stderr


@pytest.mark.skipif(len(_core.build_info()["isa_compiled"]) == len(AVAILABLE),
                    reason="this CPU supports every variant compiled in")
def test_unsupported_variant_is_refused_at_import():
    missing = [v for v in _core.build_info()["isa_compiled"] if v not in AVAILABLE][-1]
    out = run_probe(missing)
    assert out.returncode != 0 and "not supported by this CPU" in out.stderr


@pytest.mark.skipif(shutil.which("objdump") is None or os.uname().machine != "x86_64",
                    reason="needs binutils' objdump on x86-64")
def test_module_has_no_fused_multiply_add():
    # -ffp-contract=off: the AVX2/AVX-512 variants must not fuse a * b + c into one rounding,
    # which the baseline cannot do. (libm and libstdc++ are linked dynamically, so every
    # instruction in the module is the project's.)
    so = next(Path(_core.__file__).parent.glob("_core*.so"))
    asm = subprocess.run(["objdump", "-d", "--no-show-raw-insn", str(so)], capture_output=True,
                         text=True, check=True).stdout
    fused = [line for line in asm.splitlines()
             if any(op in line for op in ("vfmadd", "vfmsub", "vfnmadd", "vfnmsub"))]
    assert not fused, fused[:5]
    assert "zmm" in asm  # the AVX-512 variant is in the module (the check above is not vacuous)


# -- a wheel on an emulated CPU without AVX ---------------------------------------------------

QEMU = shutil.which("qemu-x86_64")


@pytest.fixture(scope="module")
def installed_wheel(tmp_path_factory):
    """The package as users get it: `pip wheel .` (incremental: pyproject's build-dir), then
    the wheel unpacked into a directory of its own (what pip install does for a wheel)."""
    wheels = tmp_path_factory.mktemp("wheel")
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-build-isolation",
                            "--no-deps", "-q", "-w", str(wheels)], capture_output=True, text=True,
                           timeout=3600, cwd=ROOT)
    assert build.returncode == 0, build.stdout + build.stderr
    (wheel,) = wheels.glob("crandall-*.whl")
    target = tmp_path_factory.mktemp("site")
    with zipfile.ZipFile(wheel) as z:
        z.extractall(target)
    assert list((target / "crandall").glob("_core*.so"))
    return target


@pytest.mark.skipif(sys.platform != "linux" or os.uname().machine != "x86_64" or QEMU is None,
                    reason="needs an x86-64 Linux host with qemu-user's qemu-x86_64 "
                           "(Debian: apt-get install qemu-user; `make deps` installs it)")
def test_wheel_runs_on_a_cpu_without_avx_with_the_same_bits(native, installed_wheel):
    site = [p for p in sys.path if p.endswith("site-packages")]
    # Nehalem: SSE4.2, no AVX. The wheel's module must import there (nothing in it compiled
    # above the baseline runs before dispatch), pick the baseline kernel, and give the bits of
    # the native run, which used the best variant of this CPU.
    prefix = [QEMU, "-cpu", "Nehalem"]
    out = run_probe(prefix=prefix, pythonpath=[str(installed_wheel), *site], timeout=1800)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    assert got["isa"] == "baseline" and got["available"] == ["baseline"]
    assert got["stats"] == native["stats"]
    assert got["newmark"] == native["newmark"]   # Newmark's block too (slammer, exact)
    assert got["split"] == native["split"]   # splitting's particles in the lanes
    # A variant the emulated CPU lacks is refused, not run into an illegal instruction.
    out = run_probe("avx2", prefix=prefix, pythonpath=[str(installed_wheel), *site], timeout=1800)
    assert out.returncode != 0 and "not supported by this CPU" in out.stderr


# -- a cluster of mixed variants ----------------------------------------------------------------

@pytest.mark.skipif(len(AVAILABLE) < 2, reason="this CPU supports only the baseline variant")
def test_cluster_with_workers_on_different_variants_gives_the_local_bits():
    distributed = pytest.importorskip("distributed")
    workers = {isa: {"cls": distributed.Nanny,
                     "options": {"nthreads": 1, "env": {"CRANDALL_ISA": isa}}}
               for isa in ("baseline", BEST)}
    # No dashboard, and ephemeral ports for the scheduler and its HTTP server: the suite must pass next to another Dask cluster
    # (a scheduler's default dashboard port, 8787, may be held).
    scheduler = {"cls": distributed.Scheduler,
                 "options": {"dashboard": False, "dashboard_address": ":0", "port": 0}}
    with distributed.SpecCluster(scheduler=scheduler, workers=workers) as cluster, \
            distributed.Client(cluster) as client:
        client.wait_for_workers(2)
        isas = client.run(lambda: __import__("crandall")._core.build_info()["isa"])
        assert sorted(isas.values()) == sorted(["baseline", BEST])
        scene = crandall.Scene.scaled(tau0=1.0, times=[0.25, 1.0, 1.5])
        paths = 8 * _core.CHUNK_PATHS + 3
        with distributed.get_task_stream(client) as tasks:
            remote = crandall.simulate(scene, paths=paths, seed=5, dt=0.1, client=client)
        ran_on = {t["worker"] for t in tasks.data}
        assert len(ran_on) == 2  # both variants did part of the work
    local = crandall.simulate(scene, paths=paths, seed=5, dt=0.1)
    assert same_result(local, remote)
    np.testing.assert_array_equal(local.moment(2, 1, 1), remote.moment(2, 1, 1))

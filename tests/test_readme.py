"""The README's Python examples, from "## Use" to the bias section, run in order, twice, in an
empty folder (the shipped scenes read by name): every call a reader copies works and can be run
again. Path counts and targets are made smaller so that the suite stays short, and the Dask
example gets a local cluster instead of the README's scheduler address: each substitution is
listed in SHRINK and must match the README (so an edited example is never silently skipped)."""

from __future__ import annotations

import os
import pathlib
import re

import pytest

import crandall

ROOT = pathlib.Path(__file__).resolve().parent.parent

#: (README text, what the test runs instead): smaller runs of the same calls.
SHRINK = [
    ("paths=100_000", "paths=2_000"),
    ("paths=10**8", "paths=3 * 65536"),
    ("paths=10**9", "paths=2 * 65536"),
    ("paths=10**6", "paths=20_000"),
    ("error=1e-3, seed=1, statistics", "error=2e-2, seed=1, statistics"),
    ('[0.5, 1.0], rel_error=0.2, seed=1)', '[0.5, 1.0], rel_error=0.5, seed=1, particles=50)'),
    ('[1.0, 1.4, 2.0], rel_error=0.2, seed=1)', '[1.0, 1.4, 2.0], rel_error=0.5, seed=1, dt=0.04)'),
    ('Client("tcp://scheduler:8786")',
     'Client(LocalCluster(n_workers=1, threads_per_worker=1, processes=False, '
     'dashboard_address=":0"))'),
]


def _examples() -> str:
    text = (ROOT / "README.md").read_text()
    use = text[text.index("## Use"):text.index("## Bias of the integrals")]
    blocks = re.findall(r"```python\n(.*?)```", use, re.S)
    code = "\n".join(blocks)
    for old, new in SHRINK:
        assert old in code, f"the README no longer has {old!r}: update SHRINK"
        code = code.replace(old, new)
    return code


def test_the_readme_examples_run_twice_in_order(tmp_path, monkeypatch):
    pytest.importorskip("xarray")
    pytest.importorskip("matplotlib")
    pytest.importorskip("distributed")
    pytest.importorskip("boost_histogram")
    pytest.importorskip("pyslammer")   # the records' example reads its shipped records
    monkeypatch.chdir(tmp_path)
    code = "from distributed import LocalCluster\n" + _examples()
    for run in range(2):
        namespace: dict = {}
        # The crate's velocity at 3 s, a second after the shaking, is 0 on every path: its
        # variance's standard error is NaN, and result.to_pandas() says so.
        with pytest.warns(crandall.StatisticsWarning, match="variance of velocity"):
            exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102 - the README's code
        client = namespace.get("client")
        if client is not None:
            cluster = client.cluster
            client.close()
            cluster.close()
    assert os.path.exists("crate.nc") and os.path.exists("accurate.nc")


def _mypy(tmp_path, code: str, *options: str):
    """mypy on ``code`` (written to a file in tmp_path), against the package's annotations."""
    import subprocess
    import sys
    path = tmp_path / "readme_examples.py"
    path.write_text(code)
    env = dict(os.environ, MYPYPATH=str(ROOT / "python"))
    return subprocess.run([sys.executable, "-m", "mypy", *options, "--follow-imports=silent",
                           "--ignore-missing-imports", "--cache-dir", str(tmp_path / "cache"),
                           str(path)], capture_output=True, text=True, env=env, cwd=tmp_path)


def _readme_code() -> str:
    """The README's Python examples as written (no SHRINK: what a reader's type checker sees)."""
    text = (ROOT / "README.md").read_text()
    use = text[text.index("## Use"):text.index("## Bias of the integrals")]
    return "\n".join(re.findall(r"```python\n(.*?)```", use, re.S))


def test_the_readme_examples_type_check(tmp_path):
    # mypy on the README's examples as written, against the package's annotations
    # (simulate -> Result, the statistics, intervals, files): a call the annotations do not
    # allow, or a method that does not exist, fails here.
    pytest.importorskip("mypy")
    done = _mypy(tmp_path, _readme_code())
    assert done.returncode == 0, done.stdout + done.stderr
    # The check can fail: a misspelt method is an error.
    done = _mypy(tmp_path, "import crandall\nr = crandall.simulate(crandall.Scene.scaled("
                           "tau0=1.0, times=[1.0]), paths=10)\nr.meen('distance')\n")
    assert done.returncode == 1 and "has no attribute \"meen\"" in done.stdout


def test_the_readme_examples_pass_mypy_strict_but_for_dask(tmp_path):
    # The package's annotations hold under --strict too: the one call strict mypy refuses is
    # Dask's Client, which distributed ships without annotations.
    pytest.importorskip("mypy")
    done = _mypy(tmp_path, _readme_code(), "--strict")
    errors = [line for line in done.stdout.splitlines() if ": error:" in line]
    # mypy ran to its verdict (0: clean, 1: errors found), and every error is Client's.
    assert done.returncode in (0, 1) and ("Success" in done.stdout or "Found" in done.stdout), \
        done.stdout + done.stderr
    assert all('untyped function "Client"' in line for line in errors), done.stdout

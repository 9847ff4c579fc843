"""A notebook, as a user runs one (nbclient and ipykernel, which make test installs): figures
show as pictures without ``%matplotlib inline``, a run shows a progress bar where a person
watches, and results (a run's, a tail's) show as HTML tables."""

from __future__ import annotations

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")
pytest.importorskip("matplotlib")

CELLS = [
    "import crandall\n"
    "from crandall import plots\n"
    "scene = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0, 2.0])",
    # The default's test for a person watching: true in a notebook's kernel.
    "crandall._resources._interactive()",
    "result = crandall.simulate(scene, paths=20_000, seed=1, progress=True)\nresult",
    "plots.distance_mean(result)",
    "crandall.tail(scene, 'stop_time', [1.5], seed=1, rel_error=0.3)",
]


def _outputs(tmp_path, monkeypatch):
    # The kernel inherits this process's environment: without the markers of a test run or
    # CI, as a user's notebook has it.
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.delenv("PYTEST_CURRENT_TEST", raising=False)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(c) for c in CELLS]
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    return [cell.outputs for cell in nb.cells]


def test_a_notebook_shows_figures_a_progress_bar_and_tables(tmp_path, monkeypatch):
    imports, interactive, run, figure, tail = _outputs(tmp_path, monkeypatch)
    assert imports == []
    assert interactive[0]["data"]["text/plain"] == "True"
    # The bar: a widget where ipywidgets is installed, else tqdm's text on stderr.
    kinds = {key for out in run for key in out.get("data", {})}
    streams = "".join(out.get("text", "") for out in run if out["output_type"] == "stream")
    assert "application/vnd.jupyter.widget-view+json" in kinds or "crandall" in streams, run
    html = [out["data"]["text/html"] for out in run if "text/html" in out.get("data", {})]
    assert html and "<table" in html[-1]
    shown = figure[-1]["data"]
    assert "image/png" in shown, figure
    assert shown["text/plain"].startswith("<Figure")
    # Every kind of result has its HTML table.
    shown = [out["data"] for out in tail if "data" in out][-1]
    assert "<table" in shown["text/html"] and "stop_time" in shown["text/html"]

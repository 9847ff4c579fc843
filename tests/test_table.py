"""The statistics table every result builds once (crandall.results.table) and that its shown
forms render: its columns agree with the result's own answers, and the renderers read the
table and nothing else."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import crandall
from crandall import _frames, _render
from crandall.results import render_text
from crandall.results.table import STATISTICS_COLUMNS, Table

SCENE = crandall.Scene.scaled(tau0=5.0, times=[1.0, 5.0],
                              observe=["velocity", "displacement", "distance", "stop"])


@pytest.fixture(scope="module")
def result():
    return crandall.simulate(SCENE, paths=2_000, seed=21, method="exact", threads=1)


def _row(table, name, stat):
    return table.rows(quantity=name, statistic=stat)


def test_the_columns_are_the_results_answers(result):
    table = result._statistics_table()
    assert not table.bias_pending and table.layout == "statistics"
    assert table.quantities() == list(result.names)
    c = table.columns
    for name in result.names:
        for stat in ("mean", "var"):
            rows = _row(table, name, stat)
            value = result.mean(name) if stat == "mean" else result.var(name)
            stderr = result.stderr(name) if stat == "mean" else result.var_stderr(name)
            np.testing.assert_array_equal(c["value"][rows], np.atleast_1d(value))
            np.testing.assert_array_equal(c["stderr"][rows], np.atleast_1d(stderr))
            np.testing.assert_array_equal(c["bias"][rows],
                                          np.atleast_1d(result.bias(name, stat)))
            np.testing.assert_array_equal(c["error"][rows],
                                          np.atleast_1d(result.error(name, stat)))
            lo, hi = result.interval(name, stat)
            np.testing.assert_allclose(c["lower"][rows], np.atleast_1d(lo), rtol=1e-15)
            np.testing.assert_allclose(c["upper"][rows], np.atleast_1d(hi), rtol=1e-15)
            assert set(c["exact"][rows]) == {result.exact(name, stat)}
            assert set(c["bound"][rows]) == {result.bias_is_bound(name, stat)}
            np.testing.assert_array_equal(c["std"][rows], np.atleast_1d(result.std(name)))
    # The exact step makes the velocity's statistics exact, not the distance's.
    assert c["exact"][_row(table, "velocity", "mean")].all()
    assert not c["exact"][_row(table, "distance", "mean")].any()


def test_a_run_to_an_accuracy_marks_the_statistics_it_did_not_estimate():
    r = crandall.simulate(SCENE, error=8e-2, seed=3, threads=1,
                          statistics=["velocity:var", "stop_time:mean"])
    table = r._statistics_table()
    c = table.columns
    assert table.layout == "statistic_rows" and table.quantities() == list(r.names)
    for name in r.names:
        for stat in ("mean", "var"):
            rows = _row(table, name, stat)
            estimated = stat in r.stats_of(name)
            assert set(c["estimated"][rows]) == {estimated}
            if estimated:
                np.testing.assert_array_equal(c["value"][rows], np.atleast_1d(
                    r.mean(name) if stat == "mean" else r.var(name)))
                assert set(c["exact"][rows]) == {r.exact(name, stat)}
            else:
                assert np.isnan(c["value"][rows]).all()


def test_the_renderers_read_the_table_only(result):
    table = result._statistics_table()
    columns = dict(table.columns)
    value = columns["value"].copy()
    first = _row(table, "velocity", "mean")[0]
    value[first] = 123.456
    columns["value"] = value
    changed = dataclasses.replace(table, columns=columns,
                                  text_header=("a header of its own",))
    text = render_text.text(changed)
    assert text.startswith("a header of its own\n") and "123.456" in text
    assert "123.456" not in result.summary()
    assert "123.456" in _render.html_table(changed)
    pytest.importorskip("pandas")
    frame = _frames.table_pandas(changed)
    assert frame["mean"].iloc[0] == 123.456
    tidy = _frames.table_pandas(changed, tidy=True)
    assert 123.456 in tidy["value"].tolist()


def test_a_tail_is_one_table_too():
    tail = crandall.TailResult(
        quantity="stop_time", levels=np.array([1.0, 2.0]), units="s",
        probability=np.array([0.5, 0.1]), stderr=np.array([0.01, 0.02]),
        rel_error=np.array([0.02, 0.2]), method="importance", samples=500, seconds=1.0,
        steps=10, diagnostics={}, reliable=np.array([True, False]))
    table = tail._statistics_table()
    lo, hi = tail.interval()
    np.testing.assert_array_equal(table.columns["lower"], lo)
    np.testing.assert_array_equal(table.columns["upper"], hi)
    assert render_text.text(table) == str(tail)
    assert _render.html_table(table) == tail._repr_html_()


def test_a_table_refuses_columns_that_are_not_its_layouts():
    columns = {k: np.zeros(1) for k in STATISTICS_COLUMNS}
    Table("statistics", "t", (), (), columns)
    with pytest.raises(ValueError, match="layout"):
        Table("wide", "t", (), (), columns)
    with pytest.raises(ValueError, match="columns"):
        Table("levels", "t", (), (), columns)
    with pytest.raises(ValueError, match="one entry per row"):
        Table("statistics", "t", (), (), {**columns, "value": np.zeros(2)})

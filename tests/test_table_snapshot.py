"""Every shown form of a result (summary, HTML, pandas, CSV, xarray) stays what it was: the
snapshot tests/data/table_snapshot.json keeps them for a few results of each kind, fixed seeds
(tests/table_snapshot.py makes them; run it as a script to write the snapshot again, in the
commit that changes a form on purpose)."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("xarray")

from table_snapshot import SNAPSHOT, results, forms  # noqa: E402

STORED = json.loads(SNAPSHOT.read_text())
MADE = {}


def _made(name):
    if not MADE:
        MADE.update((n, forms(r)) for n, r in results())
    return MADE[name]


@pytest.mark.parametrize("name", sorted(STORED))
def test_every_form_of_a_result_is_the_stored_one(name):
    made, stored = _made(name), STORED[name]
    assert sorted(made) == sorted(stored)
    for form in stored:
        assert made[form] == stored[form], f"{name}: {form}"


def test_the_snapshot_holds_every_kind_and_its_marks():
    # Something to differ in: each kind, a bias not estimated yet, few carrying paths, one
    # path, statistics not asked for, an unreliable tail level.
    text = {k: v["summary"] for k, v in STORED.items()}
    assert "bias: not estimated yet" in text["fixed_pending"]
    assert "n/a*" in text["fixed_si_euler"] and "n/a" in text["fixed_one_path"]
    assert "method=mlmc" in text["accuracy"] and "exact" in text["accuracy"]
    assert "\n  displacement\n" in text["accuracy"]
    assert "\n  displacement\n" not in text["accuracy_some"]
    assert "UNRELIABLE" in text["tail_by_hand"]
    assert STORED["fixed_si_euler"]["pandas_warnings"]

"""The stored bits of the snapshot tests (test_bitwise_snapshot.py, test_filtered_snapshot.py,
test_tail_snapshot.py): comparing a run's with the file's, and writing the file anew (only for
a change meant to move the numbers, said in its commit)."""

from __future__ import annotations

import json
import pathlib
import sys
from typing import Any, Callable, Dict


def assert_same_bits(path: pathlib.Path, now: Dict[str, Dict[str, Any]]) -> None:
    """Every label's entries in ``now`` equal the stored ones, the same labels and keys."""
    stored = json.loads(path.read_text())
    assert sorted(now) == sorted(stored)
    for label in stored:
        diff = [k for k in stored[label] if stored[label][k] != now[label].get(k)]
        assert not diff and sorted(now[label]) == sorted(stored[label]), (
            f"{label}: {len(diff)} values changed bits, e.g. {diff[:5]}")


def regenerate(path: pathlib.Path, snapshot: Callable[[], Dict[str, Any]], script: str) -> None:
    """The snapshot script's command line: ``python tests/SCRIPT --regenerate``."""
    if sys.argv[1:] != ["--regenerate"]:
        sys.exit(f"usage: python tests/{script} --regenerate")
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(snapshot(), indent=1, sort_keys=True) + "\n")
    print(f"wrote {path}")

"""The NumPy reference of the core's bins (tests/histogram_reference.py) against NumPy's own
histogram, and the data file the C++ tests read (tests/data/histogram_cells.txt) against the
reference: so the core's edges and lookup are checked against the documented formula through
an implementation independent of the core."""

import pathlib

import numpy as np
import pytest

import histogram_reference as ref

ROOT = pathlib.Path(__file__).resolve().parent.parent


def test_golden_file_is_the_references_output():
    # If this fails after a deliberate change of the scheme, regenerate the file with
    # `python tests/histogram_reference.py` (and the C++ test then checks the core against it).
    assert (ROOT / ref.GOLDEN_PATH).read_text() == ref.golden_text()


@pytest.mark.parametrize("axis", ref.GOLDEN_AXES)
def test_reference_cells_agree_with_numpy_histogram(axis):
    edges = ref.log_linear_edges(*axis)
    x = ref.golden_values(edges)
    counts, under, over, nan = ref.histogram(edges, x)
    finite = x[np.isfinite(x)]
    # numpy.histogram closes its last bin; values equal to the top edge are overflow here.
    inside = finite[(finite >= edges[0]) & (finite < edges[-1])]
    np_counts, _ = np.histogram(inside, bins=edges)
    np.testing.assert_array_equal(counts, np_counts)
    assert under == np.count_nonzero(x < edges[0])
    assert over == np.count_nonzero(x >= edges[-1])
    assert nan == np.count_nonzero(np.isnan(x))


@pytest.mark.parametrize("axis", ref.GOLDEN_AXES)
def test_reference_edges_as_documented(axis):
    scale, m, reach, symmetric = axis
    e = ref.log_linear_edges(*axis)
    assert np.all(np.diff(e) > 0)
    # The atom edge 2^-1074 just above 0: the bin [0, 2^-1074) holds exact zeros only.
    atom = np.flatnonzero(e == 5e-324)
    assert atom.size == 1 and e[atom[0] - 1] == 0.0
    rest = np.delete(e, atom[0])
    b = rest[rest > 0][m - 1]  # b/m, 2b/m, ..., b: the m-th positive edge
    np.testing.assert_array_equal(rest[rest > 0][:m], np.arange(1, m + 1) * (b / m))
    assert b == 2.0 ** np.floor(np.log2(b)) and b <= scale < 2 * b
    assert e[-1] >= reach * scale and (e[-1] / 2 < reach * scale or e[-1] == b)
    positive = e[e >= b]
    rel = np.diff(positive) / positive[:-1]
    assert np.all(rel <= 1.0 / m) and np.all(rel >= 0.5 / m)
    if symmetric:
        np.testing.assert_array_equal(rest, -rest[::-1])
    else:
        assert e[0] == 0.0

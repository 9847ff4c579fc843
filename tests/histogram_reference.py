"""NumPy reference of the core's histogram bins (docs/methods/histograms.md), written from the
documented formula alone, for the tests: the edges of the automatic scheme, and the cell of a
value by the definition (the number of edges <= x), with NaN apart."""

import numpy as np


def log_linear_edges(scale, per_octave, max_scales, symmetric):
    """Edges of the automatic scheme: b the power of two with b <= scale < 2b, m = per_octave;
    0, b/m, ..., (m-1) b/m, then (m + j) b 2^k / m for k < K, j < m, then b 2^K with K the least
    such that b 2^K >= max_scales * scale; mirrored at 0 if symmetric; and the atom edge 2^-1074
    just above 0 (not mirrored). All exact in float64."""
    m = int(per_octave)
    b = 2.0 ** (np.floor(np.log2(scale)))
    # np.log2 may round near a power of two: settle b by exact comparisons.
    while b > scale:
        b /= 2.0
    while 2.0 * b <= scale:
        b *= 2.0
    parts = [np.arange(m) * (b / m)]
    octave = b
    while octave < scale * max_scales:
        parts.append(octave + np.arange(m) * (octave / m))
        octave *= 2.0
    out = np.concatenate(parts + [[octave]])
    # The atom cell [0, 2^-1074) above 0: exact zeros apart (not mirrored below 0).
    atom = np.concatenate(([0.0, 5e-324], out[1:]))
    if symmetric:
        return np.concatenate((-out[:0:-1], atom))
    return atom


def cells(edges, x):
    """Cell of every value: 0 underflow, 1 + j bin j, n + 1 overflow, n + 2 NaN (n bins)."""
    edges = np.asarray(edges, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    out = np.searchsorted(edges, x, side="right")
    return np.where(np.isnan(x), edges.size + 1, out)


def histogram(edges, x):
    """(counts, under, over, nan) of the values x, by the definition."""
    n = len(edges) - 1
    c = np.bincount(cells(edges, x), minlength=n + 3)
    return c[1:n + 1], int(c[0]), int(c[n + 1]), int(c[n + 2])


# Axes and values of tests/data/histogram_cells.txt, which the C++ test reads to check the
# core's edges and lookup against this reference (regenerate: python tests/histogram_reference.py).
GOLDEN_AXES = [  # scale, per_octave, max_scales, symmetric
    (0.5 ** 0.5, 16, 50.0, True),
    (0.25, 8, 50.0, False),
    (1e-7, 4, 1.0, True),
    (1234.5, 2, 3.0, False),
]
GOLDEN_PATH = "tests/data/histogram_cells.txt"


def golden_values(edges):
    """Every edge, one ulp either side, the midpoints, magnitudes 2^-40..2^10 times the top
    edge of both signs, and the special values."""
    e = np.asarray(edges)
    top = e[-1]
    grid = top * 2.0 ** np.linspace(-40.0, 10.0, 101)
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324,
                        np.finfo(np.float64).max, -np.finfo(np.float64).max])
    return np.concatenate((e, np.nextafter(e, -np.inf), np.nextafter(e, np.inf),
                           0.5 * (e[:-1] + e[1:]), grid, -grid, special))


def golden_text():
    lines = ["# Cells of values by tests/histogram_reference.py (NumPy), read by",
             "# cpp/tests/test_histogram.cpp. Per axis: 'axis scale per_octave max_scales",
             "# symmetric n_edges n_values', the edges, then 'value cell' (cell 0 underflow,",
             "# 1 + j bin j, n + 1 overflow, n + 2 NaN). Numbers in C99 hex (exact)."]
    for scale, m, reach, symmetric in GOLDEN_AXES:
        edges = log_linear_edges(scale, m, reach, symmetric)
        values = golden_values(edges)
        lines.append(f"axis {float(scale).hex()} {m} {float(reach).hex()} {int(symmetric)} "
                     f"{edges.size} {values.size}")
        lines.extend(float(x).hex() for x in edges)
        lines.extend(f"{float(x).hex()} {c}" for x, c in zip(values, cells(edges, values)))
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    with open(GOLDEN_PATH, "w") as f:
        f.write(golden_text())

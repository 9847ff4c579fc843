"""NumPy reference of the core's histogram bins (docs/methods/histograms.md), written from the
documented formula alone, for the tests: the edges of the automatic scheme, and the cell of a
value by the definition (the number of edges <= x), with NaN apart."""

import numpy as np


def log_linear_edges(scale, per_octave, max_scales, symmetric):
    """Edges of the automatic scheme: b the power of two with b <= scale < 2b, m = per_octave;
    0, b/m, ..., (m-1) b/m, then (m + j) b 2^k / m for k < K, j < m, then b 2^K with K the least
    such that b 2^K >= max_scales * scale; mirrored at 0 if symmetric. All exact in float64."""
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
    if symmetric:
        return np.concatenate((-out[:0:-1], out))
    return out


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

"""Quantiles, exceedance probabilities and boost-histogram export from binned counts
(crandall.distributions), against NumPy on samples of known laws, with exact checks of the
interval construction and coverage over many seeds."""

import math
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import optimize, special, stats

import histogram_reference as ref
from crandall import distributions as dist

# The velocity's stationary law in scaled units: density exp(-2|u|), P(U > x) = exp(-2x) / 2.
SCALE = math.sqrt(0.5)


def laplace(rng, n):
    return rng.laplace(0.0, 0.5, n)


def laplace_sf(x):
    return 0.5 * math.exp(-2.0 * x) if x >= 0 else 1.0 - 0.5 * math.exp(2.0 * x)


def laplace_quantile(q):
    return -0.5 * math.log(2.0 * (1.0 - q)) if q >= 0.5 else 0.5 * math.log(2.0 * q)


def binned(edges, x):
    counts, under, over, nan = ref.histogram(edges, x)
    assert nan == 0
    return counts, under, over


EDGES = ref.log_linear_edges(SCALE, 16, 50.0, True)


# ---------------------------------------------------------------- exact checks on one sample

@pytest.fixture(scope="module")
def sample():
    return laplace(np.random.default_rng(20261121), 100_000)


@pytest.mark.parametrize("q", [0.001, 0.01, 0.1, 0.5, 0.9, 0.99, 0.999, 0.9999])
def test_quantile_against_numpy(sample, q):
    counts, under, over = binned(EDGES, sample)
    est = dist.quantile(EDGES, counts, under, over, q)
    # The sample quantile X_(ceil(q n)) (NumPy's inverted_cdf) lies in the estimate's bin and
    # between the interval's order statistics (l <= ceil(q n) <= u): exact, no tolerance.
    x_q = np.quantile(sample, q, method="inverted_cdf")
    j = np.searchsorted(EDGES, x_q, side="right") - 1
    assert EDGES[j] <= est.value <= EDGES[j + 1]
    assert est.low <= x_q <= est.high
    # The law's quantile inside the 95 % interval (a fixed seed: a 5 % chance per q of failing
    # for an interval of exact coverage, less for this conservative one).
    assert est.low <= laplace_quantile(q) <= est.high


@pytest.mark.parametrize("level", [-1.0, 0.0, 0.37, 1.0, 3.45, 4.6, 40.0])
def test_exceedance_against_numpy(sample, level):
    counts, under, over = binned(EDGES, sample)
    est = dist.exceedance(EDGES, counts, under, over, level)
    n = sample.size
    k = int(np.count_nonzero(sample > level))
    # The count above the level is bracketed by the cells, so the empirical fraction is inside
    # the interval, and the estimate is within the bracket: exact.
    i = np.searchsorted(EDGES, level, side="right")
    cells = np.concatenate(([under], counts, [over]))
    k_min, k_max = int(cells[i + 1:].sum()), int(cells[i:].sum())
    assert k_min <= k <= k_max
    assert k_min / n <= est.value <= k_max / n
    assert est.low <= k / n <= est.high
    assert est.low <= laplace_sf(level) <= est.high  # fixed seed, 95 % interval


def test_exceedance_interpolates_within_a_bin():
    edges = [0.0, 1.0, 2.0, 3.0]
    counts = [10, 20, 30]
    # A quarter of the way into bin [1, 2): 3/4 of its 20 values counted, plus the 30 above.
    est = dist.exceedance(edges, counts, 0, 0, 1.25)
    assert est.value == pytest.approx((15 + 30) / 60, abs=1e-15)
    # The interval spans both ends of the bin: Clopper-Pearson at 30 and at 50 of 60.
    lo = stats.beta.ppf(0.025, 30, 31)
    hi = stats.beta.ppf(0.975, 51, 10)
    assert est.low == pytest.approx(lo, rel=1e-12) and est.high == pytest.approx(hi, rel=1e-12)
    # On an edge: the bin above it is undecided (its values may equal the edge), so the
    # interval is as wide; the estimate counts the bin in full.
    on = dist.exceedance(edges, counts, 0, 0, 2.0)
    assert on.value == pytest.approx(30 / 60, abs=1e-15)
    assert on.low == 0.0
    assert on.high == pytest.approx(stats.beta.ppf(0.975, 31, 30), rel=1e-12)


# ---------------------------------------------------------------- properties

@st.composite
def histograms(draw):
    n = draw(st.integers(1, 8))
    steps = draw(st.lists(st.floats(1e-3, 10.0), min_size=n, max_size=n))
    edges = np.cumsum([draw(st.floats(-5.0, 5.0))] + steps)
    counts = draw(st.lists(st.integers(0, 50), min_size=n, max_size=n))
    under, over = draw(st.integers(0, 20)), draw(st.integers(0, 20))
    if sum(counts) + under + over == 0:
        counts[0] = 1
    return edges, counts, under, over


@settings(max_examples=60, derandomize=True, deadline=None, database=None)
@given(histograms(), st.lists(st.floats(0.0, 1.0), min_size=2, max_size=5),
       st.lists(st.floats(-20.0, 20.0), min_size=2, max_size=5))
def test_estimates_inside_intervals_and_monotone(h, qs, levels):
    quants = [dist.quantile(*h, q) for q in sorted(qs)]
    for est in quants:
        assert est.low <= est.value <= est.high
    # A larger probability never gives a smaller quantile, estimate or bound.
    for a, b in zip(quants, quants[1:]):
        assert a.value <= b.value and a.low <= b.low and a.high <= b.high
    excs = [dist.exceedance(*h, level) for level in sorted(levels)]
    for est in excs:
        assert 0.0 <= est.low <= est.value <= est.high <= 1.0
    for a, b in zip(excs, excs[1:]):
        assert a.value >= b.value and a.low >= b.low and a.high >= b.high


# ---------------------------------------------------------------- edge cases

def test_q_zero_and_one():
    edges = [0.0, 1.0, 2.0, 3.0, 4.0]
    counts = [0, 5, 7, 0]
    lo = dist.quantile(edges, counts, 0, 0, 0.0)
    assert lo.value == 1.0  # the lower edge of the lowest non-empty bin
    assert lo.low == -math.inf  # the law's minimum can lie below any sample
    assert lo.high == 2.0  # ... but not above the sample's minimum
    hi = dist.quantile(edges, counts, 0, 0, 1.0)
    assert hi.value == 3.0 and hi.low == 2.0 and hi.high == math.inf


def test_all_mass_in_underflow():
    edges = [0.0, 1.0, 2.0]
    est = dist.quantile(edges, [0, 0], 50, 0, 0.5)
    assert est.value == -math.inf and est.low == -math.inf and est.high == 0.0
    # Nothing is at or above the first edge: exactly zero counted above it, and the upper
    # bound is Clopper-Pearson's for 0 of 50, 1 - (alpha/2)^(1/n).
    exc = dist.exceedance(edges, [0, 0], 50, 0, 0.5)
    assert exc.value == 0.0 and exc.low == 0.0
    assert exc.high == pytest.approx(1 - 0.025 ** (1 / 50), rel=1e-12)
    # Below the first edge the counts cannot tell: anything from 0 to all of them.
    below = dist.exceedance(edges, [0, 0], 50, 0, -1.0)
    assert below.value == 0.5 and below.low == 0.0 and below.high == 1.0


def test_all_mass_in_overflow():
    est = dist.quantile([0.0, 1.0], [0], 0, 8, 0.5)
    assert est.value == math.inf and est.low == 1.0 and est.high == math.inf
    exc = dist.exceedance([0.0, 1.0], [0], 0, 8, 0.0)
    assert exc.value == 1.0 and exc.high == 1.0
    assert exc.low == pytest.approx(0.025 ** (1 / 8), rel=1e-12)
    assert dist.exceedance([0.0, 1.0], [0], 0, 8, math.inf).value == 0.0


def test_accepts_numpy_and_unsigned_counts():
    a = dist.quantile(np.array([0.0, 1.0, 2.0]), np.array([3, 4], dtype=np.uint64), np.int64(1),
                      np.uint64(2), np.float64(0.5))
    b = dist.quantile([0.0, 1.0, 2.0], [3, 4], 1, 2, 0.5)
    assert a == b


BAD = [
    ("edges", dict(edges=[1.0])),
    ("edges", dict(edges=[0.0, 0.0, 1.0])),
    ("edges", dict(edges=[0.0, 2.0, 1.0])),
    ("edges", dict(edges=[0.0, math.nan, 1.0])),
    ("edges", dict(edges=[0.0, 1.0, math.inf])),
    ("edges", dict(edges=[[0.0, 1.0, 2.0]])),
    ("counts", dict(counts=[1, 2, 3])),
    ("counts", dict(counts=[1, -2])),
    ("counts", dict(counts=[1.5, 2])),
    ("counts", dict(counts=["a", "b"])),
    ("under", dict(under=-1)),
    ("under", dict(under=0.5)),
    ("over", dict(over=-3)),
    ("over", dict(over=2**64)),
    ("counts", dict(counts=np.array([2**63, 1], dtype=np.uint64))),
    ("counts", dict(counts=[0, 0], under=0, over=0)),  # empty
]


@pytest.mark.parametrize("name,bad", BAD)
def test_bad_histograms_named(name, bad):
    args = dict(edges=[0.0, 1.0, 2.0], counts=[1, 2], under=0, over=0)
    args.update(bad)
    with pytest.raises(ValueError, match=name):
        dist.quantile(q=0.5, **args)
    with pytest.raises(ValueError, match=name):
        dist.exceedance(level=0.5, **args)


@pytest.mark.parametrize("q", [-0.1, 1.1, math.nan, "0.5", None])
def test_bad_q(q):
    with pytest.raises(ValueError, match="q"):
        dist.quantile([0.0, 1.0], [3], 0, 0, q)


@pytest.mark.parametrize("confidence", [0.0, 1.0, -0.5, math.nan, "high"])
def test_bad_confidence(confidence):
    with pytest.raises(ValueError, match="confidence"):
        dist.quantile([0.0, 1.0], [3], 0, 0, 0.5, confidence=confidence)
    with pytest.raises(ValueError, match="confidence"):
        dist.exceedance([0.0, 1.0], [3], 0, 0, 0.5, confidence=confidence)


@pytest.mark.parametrize("level", [math.nan, "1", None])
def test_bad_level(level):
    with pytest.raises(ValueError, match="level"):
        dist.exceedance([0.0, 1.0], [3], 0, 0, level)


# ---------------------------------------------------------------- boost-histogram

def test_to_boost_histogram_same_bins_as_the_definition():
    bh = pytest.importorskip("boost_histogram")
    rng = np.random.default_rng(5)
    # Values on every edge, one ulp either side, -0.0 and the infinities: boost-histogram's
    # own fill must put them in the cells the definition (and the core) does.
    x = np.concatenate((laplace(rng, 20000) * 20, EDGES, np.nextafter(EDGES, -np.inf),
                        np.nextafter(EDGES, np.inf), [-0.0, 0.0, np.inf, -np.inf]))
    counts, under, over = binned(EDGES, x)
    h = dist.to_boost_histogram(EDGES, counts, under, over)
    assert isinstance(h, bh.Histogram)
    np.testing.assert_array_equal(h.axes[0].edges, EDGES)
    np.testing.assert_array_equal(h.view(flow=True), np.concatenate(([under], counts, [over])))
    filled = bh.Histogram(bh.axis.Variable(EDGES), storage=bh.storage.Int64()).fill(x)
    np.testing.assert_array_equal(filled.view(flow=True), h.view(flow=True))
    assert h.sum(flow=True) == x.size


def test_to_boost_histogram_needs_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "boost_histogram", None)  # makes the import fail
    with pytest.raises(ImportError, match=r"crandall\[hist\]"):
        dist.to_boost_histogram([0.0, 1.0], [1], 0, 0)


def test_to_boost_histogram_validates():
    with pytest.raises(ValueError, match="counts"):
        dist.to_boost_histogram([0.0, 1.0], [1, 2], 0, 0)


# ---------------------------------------------------------------- coverage over many seeds

ALPHA = 0.05
SEEDS = 2000
N = 400
# Two axes: the automatic one with only 2 bins per octave (bins limit the intervals a lot) and
# one with bins of width 1e-3 (they hardly do).
COARSE = ref.log_linear_edges(SCALE, 2, 50.0, True)
FINE = np.linspace(-12.0, 12.0, 24001)


def ranks(n, q):
    """Order-statistic ranks, derived here by scanning the binomial cdf: l the largest rank
    with P(B < l) <= alpha/2 and u the least with P(B >= u) <= alpha/2, B ~ binomial(n, q)."""
    k = np.arange(n + 2)
    cdf_below = stats.binom.cdf(k - 1, n, q)      # P(B < k)
    tail = stats.binom.sf(k - 1, n, q)            # P(B >= k)
    lo = int(k[cdf_below <= ALPHA / 2].max())
    hi = int(k[tail <= ALPHA / 2].min())
    return lo, hi


def clopper_pearson_by_root(k, n):
    """Clopper-Pearson bounds from their definition, P(B >= k | p_low) = alpha/2 and
    P(B <= k | p_high) = alpha/2, solved by root finding (not from the beta quantiles)."""
    low = 0.0 if k == 0 else optimize.brentq(lambda p: special.bdtrc(k - 1, n, p) - ALPHA / 2,
                                             1e-300, 1.0, xtol=1e-300, rtol=1e-14)
    high = 1.0 if k == n else optimize.brentq(lambda p: special.bdtr(k, n, p) - ALPHA / 2,
                                              0.0, 1.0 - 1e-16, xtol=1e-300, rtol=1e-14)
    return low, high


def coverage_tolerance(c):
    """Three standard errors of a coverage c estimated from SEEDS independent seeds."""
    return 3.0 * math.sqrt(c * (1.0 - c) / SEEDS)


def check_coverage(raw_hits, hits, exact):
    """The raw-sample interval covers at its exact rate ``exact`` (two-sided, 3 standard
    errors of the coverage estimate from SEEDS seeds) ... and the binned intervals, which
    contain it, cover at least as often, and at least at the stated rate (one-sided: the bins
    can only widen)."""
    raw = raw_hits / SEEDS
    assert abs(raw - exact) <= coverage_tolerance(exact), (raw, exact)
    for name, h in hits.items():
        assert h >= raw_hits, name
        assert h / SEEDS >= 1 - ALPHA - coverage_tolerance(1 - ALPHA), (name, h / SEEDS)


@pytest.fixture(scope="module")
def samples():
    return [laplace(np.random.default_rng(seed), N) for seed in range(SEEDS)]


@pytest.mark.slow
@pytest.mark.parametrize("q", [0.5, 0.99])
def test_quantile_coverage(samples, q):
    truth = laplace_quantile(q)
    lo, hi = ranks(N, q)
    exact = stats.binom.cdf(hi - 1, N, q) - stats.binom.cdf(lo - 1, N, q)
    assert exact >= 1 - ALPHA
    raw_hits = 0
    hits = {"coarse": 0, "fine": 0}
    for x in samples:
        s = np.sort(x)
        raw_lo = -math.inf if lo == 0 else s[lo - 1]
        raw_hi = math.inf if hi == N + 1 else s[hi - 1]
        raw_hits += raw_lo <= truth <= raw_hi
        for name, edges in (("coarse", COARSE), ("fine", FINE)):
            est = dist.quantile(edges, *binned(edges, x), q)
            # The interval is exactly the bins of X_(l) and X_(u): lower edge and upper edge.
            j_lo = np.searchsorted(edges, raw_lo, side="right") - 1
            j_hi = np.searchsorted(edges, raw_hi, side="right")
            assert est.low == (edges[j_lo] if j_lo >= 0 else -math.inf)
            assert est.high == (edges[j_hi] if j_hi < edges.size else math.inf)
            hits[name] += est.low <= truth <= est.high
    check_coverage(raw_hits, hits, exact)  # the order statistics' exact binomial rate


@pytest.mark.slow
@pytest.mark.parametrize("level", [0.0, 1.0, laplace_quantile(0.99), 2.7])
def test_exceedance_coverage(samples, level):
    p = laplace_sf(level)
    cp = [clopper_pearson_by_root(k, N) for k in range(N + 1)]
    # The exact coverage of Clopper-Pearson at this p and n: the binomial mass of the counts
    # whose interval holds p.
    pmf = stats.binom.pmf(np.arange(N + 1), N, p)
    exact = sum(pmf[k] for k in range(N + 1) if cp[k][0] <= p <= cp[k][1])
    assert exact >= 1 - ALPHA
    raw_hits = 0
    hits = {"coarse": 0, "fine": 0}
    for x in samples:
        k = int(np.count_nonzero(x > level))
        raw_hits += cp[k][0] <= p <= cp[k][1]
        for name, edges in (("coarse", COARSE), ("fine", FINE)):
            counts, under, over = binned(edges, x)
            est = dist.exceedance(edges, counts, under, over, level)
            i = np.searchsorted(edges, level, side="right")
            cells = np.concatenate(([under], counts, [over]))
            k_min, k_max = int(cells[i + 1:].sum()), int(cells[i:].sum())
            assert k_min <= k <= k_max
            assert est.low == pytest.approx(cp[k_min][0], rel=1e-9, abs=1e-300)
            assert est.high == pytest.approx(cp[k_max][1], rel=1e-9)
            hits[name] += est.low <= p <= est.high
    check_coverage(raw_hits, hits, exact)  # Clopper-Pearson's exact rate at p

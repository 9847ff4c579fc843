"""Distributions, tails and peaks from the run itself: the run's histograms against the analytic
laws, their exact merging (threads, chunks, checkpoints, files), memory, and bad input."""

import math
import sys
import tracemalloc

import numpy as np
import pytest
from scipy import stats

import crandall
from crandall import _core, analytic, bins, engine
from crandall.results import StatisticsWarning
from crandall.spec import RunSpec

CHUNK = _core.CHUNK_PATHS
SIM = sys.modules["crandall.simulate"]


def velocity_scene(**kw):
    # The exact method steps from one output time to the next (no grid): U1 is exact in law,
    # so its histogram may be tested against the analytic law with no bias allowance.
    return crandall.Scene.scaled(tau0=2.0, times=[0.5, 2.0, 2.25],
                                 observe=["velocity", "stop"],
                                 distributions=["velocity", "stop_time"], **kw)


def counts_of(result):
    return result.accumulators.histograms.counts


def same_counts(a, b):
    ha, hb = a.accumulators.histograms, b.accumulators.histograms
    assert ha.index == hb.index
    for x, y in zip(ha.edges, hb.edges):
        assert x.tobytes() == y.tobytes()
    for x, y in zip(ha.counts, hb.counts):
        assert x.dtype == np.uint64 and y.dtype == np.uint64
        assert x.tobytes() == y.tobytes()
    return True


def chi_square_p(edges, cells, cdf, n):
    """p-value of Pearson's chi-square of binned counts against a continuous CDF, the cells
    [under, bins, over] grouped left to right until each expects at least n / 100 values (and
    at least 20, so that the statistic's chi-square law holds to a fraction of the level):
    about 100 groups, which keeps the power against a smooth misfit (fine bins split into
    hundreds of groups would spread it over as many degrees of freedom)."""
    probs = np.diff(np.concatenate(([0.0], cdf(edges), [1.0])))
    observed = np.asarray(cells[:-1], dtype=float)  # the NaN count is checked to be 0
    groups_o, groups_e, o, e = [], [], 0.0, 0.0
    least = max(20.0, n / 100)
    for ob, pr in zip(observed, probs):
        o, e = o + ob, e + n * pr
        if e >= least:
            groups_o.append(o)
            groups_e.append(e)
            o = e = 0.0
    groups_o[-1] += o
    groups_e[-1] += e
    chi2 = sum((a - b) ** 2 / b for a, b in zip(groups_o, groups_e))
    return stats.chi2.sf(chi2, len(groups_o) - 1), len(groups_o)


# The level of the goodness-of-fit tests: at a fixed seed the test is deterministic; a
# correct kernel fails it for one seed in 1000.
LEVEL = 1e-3


def test_velocity_and_stop_time_histograms_follow_the_analytic_laws():
    paths = 200_000
    r = crandall.simulate(velocity_scene(), paths=paths, seed=11, method="exact", threads=2)
    hist = r.accumulators.histograms
    for i, tau in enumerate(r.times):
        edges, cells = hist.find(i, 0)
        assert cells[-1] == 0 and int(cells.sum()) == paths
        # Bins are [e_j, e_j+1): their probabilities come from P(U1 < e), which after the
        # switch-off leaves the atom of stopped bodies at 0 to the bin starting at 0.
        atom = float(analytic.velocity_atom(tau, 2.0)) if tau > 2.0 else 0.0

        def below(y, tau=tau, atom=atom):
            return analytic.velocity_cdf(y, tau, 2.0) - atom * (np.asarray(y) == 0)
        p, groups = chi_square_p(edges, cells, below, paths)
        assert groups > 30, groups  # the test sees the shape, not a few lumps
        assert p > LEVEL, (tau, p)
    # The stop time: the core bins the time from the switch-off; the law is tau0 + |U1|/2.
    edges, cells = hist.find(len(r.times), 0)
    p, groups = chi_square_p(edges, cells, lambda t: analytic.stop_time_cdf(t + 2.0, 2.0), paths)
    assert groups > 30 and p > LEVEL, p
    # And the same through the public face: the histogram in the quantity's units, where the
    # atom bin [0, 2^-1074) joins the bin above it (t0 + 2^-1074 is t0 in doubles).
    h = r.histogram("stop_time")
    assert edges[1] == 5e-324 and (edges + 2.0)[1] == 2.0
    np.testing.assert_array_equal(h.axes[0].edges, np.delete(edges, 1) + 2.0)
    assert h.sum(flow=True) == paths


def test_the_goodness_of_fit_test_can_fail():
    # The same counts against a law 3 % wider must be rejected: the test above has power.
    paths = 200_000
    r = crandall.simulate(velocity_scene(), paths=paths, seed=11, method="exact", threads=2)
    edges, cells = r.accumulators.histograms.find(1, 0)
    p, _ = chi_square_p(edges, cells, lambda y: analytic.velocity_cdf(y / 1.03, 2.0, 2.0), paths)
    assert p < LEVEL


def test_quantiles_and_exceedances_match_the_analytic_values():
    paths = 400_000
    r = crandall.simulate(velocity_scene(), paths=paths, seed=5, method="exact", threads=2)
    for q in (0.5, 0.9, 0.99, 0.999):
        est = r.quantile("stop_time", q)
        true = float(analytic.stop_time_quantile(q, 2.0))
        assert est.low <= true <= est.high, (q, est, true)
        assert est.low <= est.value <= est.high
        v = r.quantile("velocity", q, time=2.0)
        true_v = float(analytic.velocity_quantile(q, 2.0, 2.0))
        assert v.low <= true_v <= v.high, (q, v, true_v)
    for level in (2.1, 2.5, 3.0, 3.8):
        est = r.exceedance("stop_time", level)
        true = float(analytic.stop_time_sf(level, 2.0))
        assert est.low <= true <= est.high, (level, est, true)
        assert 0 <= est.low <= est.value <= est.high <= 1
    # Intervals that say something: the 99th percentile to within a few per cent.
    est = r.quantile("stop_time", 0.99)
    assert est.high - est.low < 0.05 * est.value


@pytest.mark.slow
def test_intervals_cover_at_their_stated_rate():
    """Over many seeds, the 90 % intervals of a quantile and an exceedance cover the analytic
    value at least 90 % of the time (they are conservative: order statistics, Clopper-Pearson,
    widened to whole bins). With S seeds the number covering is binomial(S, >= 0.9); the test
    fails if it is below the 1e-4 quantile of binomial(S, 0.9)."""
    seeds, paths, conf = 1000, 2_000, 0.9
    scene = crandall.Scene.scaled(tau0=2.0, times=[2.0], observe=["velocity", "stop"],
                                  distributions=["stop_time", "velocity"])
    q_true = float(analytic.stop_time_quantile(0.9, 2.0))
    level = 2.6
    p_true = float(analytic.stop_time_sf(level, 2.0))
    v_true = float(analytic.velocity_quantile(0.99, 2.0, 2.0))
    cover = np.zeros(3, dtype=int)
    widths = []
    for seed in range(seeds):
        r = crandall.simulate(scene, paths=paths, seed=1000 + seed, method="exact", threads=1)
        a = r.quantile("stop_time", 0.9, confidence=conf)
        b = r.exceedance("stop_time", level, confidence=conf)
        c = r.quantile("velocity", 0.99, time=2.0, confidence=conf)
        cover += [a.low <= q_true <= a.high, b.low <= p_true <= b.high,
                  c.low <= v_true <= c.high]
        widths.append(a.high - a.low)
    floor = stats.binom.ppf(1e-4, seeds, conf)
    assert (cover >= floor).all(), (cover, floor)
    # Not trivially wide: the sampling half-width of the 0.9 quantile of tau_s at 2000 paths
    # is about 1.645 sqrt(0.09 / 2000) / f(q) with f = 4 e^(-4 (q - tau0)) ~ 0.4: 0.03, so
    # the interval about 0.06 wide (plus two bins of at most 1/128 of ~0.6: 0.01). Median
    # measured 0.059; intervals twice too wide would fail.
    assert np.median(widths) < 0.1, np.median(widths)


def test_histograms_are_bitwise_the_same_for_threads_chunks_checkpoints_and_files(tmp_path):
    scene = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.5], observe=["velocity", "stop",
                                                                      "peaks"],
                                  distributions=True)
    paths = 2 * CHUNK + 777  # three chunks, the last one short
    one = crandall.simulate(scene, paths=paths, seed=3, method="exact", threads=1)
    two = crandall.simulate(scene, paths=paths, seed=3, method="exact", threads=2)
    assert same_counts(one, two)
    # The chunks merged in any order give the same counts (integer addition).
    spec = RunSpec(scene, paths, 3, one.dt, "exact", one.min_steps)
    parts = [engine.run_chunks(spec, c, c + 1, 1)[0] for c in reversed(range(3))]
    total = [np.zeros_like(c) for c in counts_of(one)]
    for part in parts:
        for t, c in zip(total, part.counts):
            t += c
    for t, c in zip(total, counts_of(one)):
        assert t.tobytes() == c.tobytes()
    # A checkpointed run interrupted after its first chunk, then resumed.
    path = tmp_path / "run.ckpt"
    real = _core.run_chunk

    class Stop(Exception):
        pass

    def failing(plan, chunk, threads):
        if chunk == 1:
            raise Stop
        return real(plan, chunk, threads)

    mp = pytest.MonkeyPatch()
    mp.setattr(_core, "run_chunk", failing)
    with pytest.raises(Stop):
        crandall.simulate(scene, paths=paths, seed=3, method="exact", threads=2,
                          checkpoint=path)
    mp.undo()
    resumed = crandall.simulate(scene, paths=paths, seed=3, method="exact", threads=1,
                                checkpoint=path)
    assert same_counts(one, resumed)
    # Saved and loaded.
    pytest.importorskip("xarray")
    one.save(tmp_path / "r.nc")
    back = crandall.load(tmp_path / "r.nc")
    assert same_counts(one, back)
    assert back.quantile("stop_time", 0.99) == one.quantile("stop_time", 0.99)
    assert back.mean("peak_speed").tobytes() == one.mean("peak_speed").tobytes()
    ds = one.to_xarray()
    assert ds["histogram_velocity_counts"].sel(time=1.5).sum() == paths


def test_checkpoint_of_other_bins_is_refused(tmp_path):
    path = tmp_path / "run.ckpt"
    crandall.simulate(velocity_scene(), paths=1000, seed=1, method="exact", checkpoint=path)
    # Same scene and run, other bins: a different identity (the scene holds its bins).
    with pytest.raises(ValueError, match="bins"):
        crandall.simulate(velocity_scene(bins=64), paths=1000, seed=1, method="exact",
                          checkpoint=path)


def test_histogram_memory_does_not_grow_with_paths():
    scene = crandall.Scene.scaled(tau0=2.0, times=[1.0], observe=["velocity"],
                                  distributions=True)
    small = crandall.simulate(scene, paths=100_000, seed=1, method="exact", threads=2)
    tracemalloc.start()
    try:
        crandall.simulate(scene, paths=100_000, seed=2, method="exact", threads=2)
        _, peak_small = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        big = crandall.simulate(scene, paths=10_000_000, seed=2, method="exact", threads=2)
        _, peak_big = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    hs, hb = small.accumulators.histograms, big.accumulators.histograms
    assert hs.nbytes == hb.nbytes and [c.size for c in hs.counts] == [c.size for c in hb.counts]
    assert int(hb.counts[0].sum()) == 10_000_000
    # 100 times the paths, the same Python allocations give or take the 153 chunks' own
    # short-lived copies (a few kB each, freed as they merge): 64 kB of slack.
    assert peak_big - peak_small < 64 << 10, (peak_small, peak_big)


def test_peaks_over_the_whole_path_are_those_at_the_switch_off():
    # After the switch-off |U1| only falls and the coast adds no grid point beyond the
    # stop: the peak speed over the whole path is the one up to t0, bit for bit.
    scene = crandall.Scene.scaled(tau0=1.0, times=[0.0, 0.5, 1.0, 2.0],
                                  observe=["velocity", "displacement", "stop", "peaks"],
                                  distributions=["peak_speed", "peak_speed_at_stop"])
    r = crandall.simulate(scene, paths=20_000, seed=4, method="exact", dt=0.01)
    assert r.mean("peak_speed_at_stop") == r.mean("peak_speed")[2]
    assert r.mean("peak_speed")[0] == 0.0 and r.mean("peak_displacement")[0] == 0.0
    m = r.mean("peak_speed")
    assert (np.diff(m) >= 0).all() and m[3] == m[2]
    assert (np.diff(r.mean("peak_displacement")) >= 0).all()
    # The peak is at least the value: its quantiles lie above |U1|'s.
    for q in (0.5, 0.9):
        peak = r.quantile("peak_speed", q, time=1.0).value
        speed = float(analytic.velocity_quantile(0.5 + q / 2, 1.0))
        assert peak >= speed


def test_kinetic_and_dissipated_energy_come_from_the_velocity_and_distance_bins():
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, mass=4.0, times=[1.0, 2.0],
                           observe=["velocity", "distance", "kinetic_energy",
                                    "dissipated_energy", "stop"],
                           distributions=True)
    r = crandall.simulate(scene, paths=20_000, seed=9, method="exact", dt=0.01)
    f = scene.mass * scene.drift
    d = r.histogram("distance", 2.0)
    e = r.histogram("dissipated_energy", 2.0)
    # The atom edge 2^-1074 (exact zeros apart) stays itself in any units.
    want = d.axes[0].edges * f
    want[1] = 5e-324
    np.testing.assert_array_equal(e.axes[0].edges, want)
    np.testing.assert_array_equal(e.view(flow=True), d.view(flow=True))
    v = r.histogram("velocity", 1.0)
    k = r.histogram("kinetic_energy", 1.0)
    edges = v.axes[0].edges
    half = edges[edges >= 0]
    want = 0.5 * scene.mass * half * half
    assert half[1] == 5e-324
    want[1] = 5e-324
    np.testing.assert_array_equal(k.axes[0].edges, want)
    # Folding: P(KE > m v^2 / 2) = P(|V| > v) for v on an edge, from the same counts.
    vv = half[len(half) // 3]
    above = v.view(flow=True)
    n = above.sum()
    i = int(np.searchsorted(edges, vv))  # edges[i] == vv
    frac = (above[i + 1:].sum() + above[:int(np.searchsorted(edges, -vv)) + 1].sum()) / n
    assert r.exceedance("kinetic_energy", 0.5 * scene.mass * vv * vv, time=1.0).value == \
        pytest.approx(frac, abs=0.5 / n)
    assert k.sum(flow=True) == r.paths


def test_user_bins_and_per_octave():
    edges = [-3.0, -1.0, 0.0, 1.0, 3.0]
    scene = crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity", "stop"],
                                  distributions=["velocity", "stop_time"],
                                  bins={"velocity": edges, "stop_time": 8})
    r = crandall.simulate(scene, paths=5_000, seed=1, method="exact")
    h = r.histogram("velocity", 1.0)
    np.testing.assert_array_equal(h.axes[0].edges, edges)
    assert h.sum(flow=True) == 5_000
    assert scene.to_dict()["bins"] == {"velocity": edges, "stop_time": 8}
    again = crandall.Scene.from_dict(scene.to_dict())
    assert again.to_dict() == scene.to_dict()
    (axis,) = [a for a in bins.axes(scene) if a.name == "stop_time"]
    assert axis.per_octave == 8
    # A user's stop-time edges are in the scene's time (from the start), shown as given.
    user = [1.0, 1.25, 1.5, 2.0, 4.0]
    s2 = crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity", "stop"],
                               distributions=["stop_time"], bins={"stop_time": user})
    h2 = crandall.simulate(s2, paths=5_000, seed=1, method="exact").histogram("stop_time")
    np.testing.assert_array_equal(h2.axes[0].edges, user)
    assert h2.view(flow=True)[0] == 0  # nobody stops before the switch-off


def test_scene_without_distributions_pays_nothing():
    scene = crandall.Scene.scaled(tau0=1.0, times=[1.0])
    assert scene.distributions == () and "distributions" not in scene.to_dict()
    r = crandall.simulate(scene, paths=100, seed=1)
    assert r.accumulators.histograms is None and r.distributions == ()
    assert engine.make_plan(r.spec).options.histogram_axes == []
    with pytest.raises(ValueError, match="name: the scene did not ask"):
        r.quantile("velocity", 0.5, time=1.0)


@pytest.mark.parametrize("kwargs, match", [
    (dict(distributions=["bogus"]), "distributions: 'bogus'"),
    (dict(distributions=["peak_speed"]), "distributions: 'peak_speed'"),
    (dict(distributions=3), "distributions"),
    (dict(distributions=True, bins={"bogus": 8}), "bins: 'bogus'"),
    (dict(distributions=True, bins={"kinetic_energy": [0.0, 1.0]}), "bins.*velocity"),
    (dict(distributions=True, bins={"velocity": [0.0, 2.0, 1.0]}), "bins.*strictly increasing"),
    (dict(distributions=True, bins={"velocity": [0.0, math.nan]}), "bins.*finite"),
    (dict(distributions=True, bins={"velocity": [1.0]}), "bins.*two edges"),
    (dict(distributions=True, bins={"velocity": [-1.0, 0.0, 2.0]}), "bins.*symmetric"),
    (dict(distributions=True, bins=12), "bins.*power of two"),
    (dict(distributions=True, bins=0), "bins.*power of two"),
    (dict(distributions=True, bins=True), "bins"),
    (dict(bins=16), "bins: the scene asks for no distributions"),
])
def test_bad_scene_options(kwargs, match):
    with pytest.raises(ValueError, match=match) as info:
        crandall.Scene.scaled(tau0=1.0, times=[1.0], **kwargs)
    assert info.value.name in ("distributions", "bins")


def test_bad_result_queries():
    r = crandall.simulate(velocity_scene(), paths=2_000, seed=1, method="exact")
    with pytest.raises(ValueError, match="time: 1.0 is not an output time"):
        r.quantile("velocity", 0.5, time=1.0)
    with pytest.raises(ValueError, match="time: velocity has a distribution at every"):
        r.quantile("velocity", 0.5)
    with pytest.raises(ValueError, match="time: stop_time is a value at the stop"):
        r.quantile("stop_time", 0.5, time=2.0)
    for q in (0.0, 1.0, -0.1, 1.5, math.nan, True, "0.5"):
        with pytest.raises(ValueError, match="^q must"):
            r.quantile("stop_time", q)
    with pytest.raises(ValueError, match="^level"):
        r.exceedance("stop_time", math.nan)
    with pytest.raises(ValueError, match="^confidence"):
        r.exceedance("stop_time", 2.5, confidence=1.0)
    with pytest.raises(ValueError, match="name: 'distance'"):
        r.histogram("distance", time=2.0)
    # Not a finite number: refused, naming time and the output times (inf once passed the
    # rounding test and answered for the first output time).
    for t in ("2.0", math.inf, -math.inf, math.nan, np.float64(math.inf), True, None):
        for call in (lambda: r.quantile("velocity", 0.5, time=t),
                     lambda: r.exceedance("velocity", 0.0, time=t),
                     lambda: r.histogram("velocity", time=t)):
            with pytest.raises(ValueError, match="^time") as info:
                call()
            if t is not None:
                assert "not an output time" in str(info.value) and "0.5, 2, 2.25" in str(info.value)
    # A numpy scalar that is an output time is accepted.
    assert r.quantile("velocity", 0.5, time=np.float64(2.0)) == r.quantile("velocity", 0.5,
                                                                             time=2.0)
    # A time typed again (2.25 from a sum) is the output time it rounds to.
    assert r.quantile("velocity", 0.5, time=2.0 + 0.25) == r.quantile("velocity", 0.5,
                                                                         time=2.25)


def test_scene_file_keys(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[scene]\nunits = "scaled"\ntau0 = 1.0\ntimes = [1.0]\n'
                    'observe = ["velocity", "stop", "peaks"]\n'
                    'distributions = ["velocity", "stop_time", "peak_speed_at_stop"]\n'
                    '[scene.bins]\nvelocity = 64\nstop_time = [1.0, 1.5, 3.0]\n')
    s = crandall.Scene.from_toml(path)
    assert s.distributions == ("velocity", "stop_time", "peak_speed_at_stop")
    assert s.bins == {"velocity": 64, "stop_time": [1.0, 1.5, 3.0]}
    path.write_text('[scene]\nunits = "scaled"\ntau0 = 1.0\ntimes = [1.0]\n'
                    'distributions = ["bogus"]\n')
    with pytest.raises(ValueError, match="scene.distributions"):
        crandall.Scene.from_toml(path)
    path.write_text('[scene]\nunits = "scaled"\ntau0 = 1.0\ntimes = [1.0]\n'
                    'distributions = true\nbins = [1.0, 2.0]\n')
    with pytest.raises(ValueError, match="scene.bins"):
        crandall.Scene.from_toml(path)


def test_nan_counts_warn():
    r = crandall.simulate(velocity_scene(), paths=100, seed=1, method="exact")
    hist = r.accumulators.histograms
    hist.counts[0][-1] += 1  # a NaN, as no sane run gives
    with pytest.warns(StatisticsWarning, match="NaN"):
        r.quantile("velocity", 0.5, time=0.5)


def test_cli_prints_the_stop_quantiles_and_draws_the_run_s_distributions(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from crandall import cli

    path = tmp_path / "s.toml"
    path.write_text('[scene]\nunits = "scaled"\ntau0 = 1.0\ntimes = [0.5, 1.0, 2.0]\n'
                    'distributions = true\n[run]\npaths = 4000\nseed = 3\ndt = 0.05\n')
    out = tmp_path / "out"
    assert cli.main(["run", str(path), "--out", str(out), "--threads", "1"]) == 0
    text = capsys.readouterr().out
    r = crandall.load(out / "result.nc")
    assert "Quantiles at the stop" in text
    for name in ("stop_time", "displacement_at_stop", "distance_at_stop",
                 "dissipated_energy_at_stop"):
        e = r.quantile(name, 0.999)
        assert f"{e.value:.4g} [{e.low:.4g}, {e.high:.4g}]" in text, name
        assert name in text
    written = {p.name for p in out.iterdir()}
    assert {"velocity_density.png", "stop_time_density.png",
            "distance_at_stop_distribution.png", "displacement_at_stop_distribution.png",
            "dissipated_energy_at_stop_distribution.png"} <= written
    # A scene without distributions prints no quantiles.
    assert cli.quantile_table(crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[1.0]),
                                                paths=100, seed=1)) == ""


def test_distribution_figure_bad_input():
    pytest.importorskip("matplotlib")
    from crandall import plots

    r = crandall.simulate(velocity_scene(), paths=2_000, seed=1, method="exact")
    fig = plots.distribution(r, "velocity")
    assert len(fig.axes) == 2 and fig.axes[1].get_yscale() == "log"
    with pytest.raises(ValueError, match="name"):
        plots.distribution(r, "distance")
    with pytest.raises(ValueError, match="times"):
        plots.distribution(r, "stop_time", times=[1.0])
    with pytest.raises(ValueError, match="time: 7.0 is not"):
        plots.distribution(r, "velocity", times=[7.0])


def test_the_layout_of_the_axes_is_the_cores():
    assert bins.VARIABLE_COUNT == _core.HISTOGRAM_VARIABLES
    scene = crandall.Scene.scaled(tau0=1.0, times=[0.5, 2.0], observe=["distance", "stop"],
                                  distributions=["distance", "distance_at_stop"])
    plan = engine.make_plan(RunSpec(scene, 10, 1, 0.1, "exact"))
    axes = plan.options.histogram_axes
    assert len(axes) == 3 * bins.VARIABLE_COUNT
    assert [i for i, a in enumerate(axes) if a.bins] == [2, 7, 12]


def test_physical_scene_quantiles_are_the_scaled_law_in_si():
    # mu = 0.3, h = 1: the automatic bins come from scaled scales converted to SI; the
    # quantiles must be the scaled laws' times the scales (stop time: from the start).
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[1.0, 2.0],
                           observe=["velocity", "kinetic_energy", "stop"],
                           distributions=True)
    s = scene.scaling
    tau0 = s.to_tau(2.0)
    r = crandall.simulate(scene, paths=200_000, seed=6, method="exact", threads=2)
    for q in (0.5, 0.99):
        est = r.quantile("stop_time", q)
        true = s.to_t(float(analytic.stop_time_quantile(q, tau0)))
        assert est.low <= true <= est.high, (q, est, true)
        v = r.quantile("velocity", q, time=1.0)
        true_v = s.to_si(float(analytic.velocity_quantile(q, s.to_tau(1.0))), "velocity")
        assert v.low <= true_v <= v.high, (q, v, true_v)
    k = r.quantile("kinetic_energy", 0.99, time=1.0)
    speed = s.to_si(float(analytic.velocity_quantile(0.995, s.to_tau(1.0))), "velocity")
    assert k.low <= 0.5 * scene.mass * speed ** 2 <= k.high


def test_dissipated_energy_without_friction_has_no_distribution():
    scene = crandall.Scene(mu=0.0, h=1.0, t0=1.0, times=[1.0], distributions=True)
    r = crandall.simulate(scene, paths=500, seed=1)
    assert math.isfinite(r.quantile("distance", 0.9, time=1.0).value)
    with pytest.raises(ValueError, match="name: dissipated_energy is 0 on every path"):
        r.quantile("dissipated_energy", 0.9, time=1.0)


def test_old_or_damaged_checkpoints_are_refused(tmp_path):
    import json

    path = tmp_path / "run.ckpt"
    scene = velocity_scene()
    crandall.simulate(scene, paths=1000, seed=1, method="exact", checkpoint=path)
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files}

    def write(**changes):
        bad = dict(arrays, **changes)
        with open(path, "wb") as f:
            np.savez(f, **bad)

    ident = json.loads(str(arrays["identity"]))
    write(identity=np.array(json.dumps(dict(ident, format_version=2))))
    with pytest.raises(ValueError, match="checkpoint format 2.*cannot be continued"):
        crandall.simulate(scene, paths=1000, seed=1, method="exact", checkpoint=path)
    counts = arrays["histogram_counts"].copy()
    counts[5] += 1
    write(histogram_counts=counts)
    with pytest.raises(ValueError, match="histogram_counts of axis 0 add up to 1001"):
        crandall.simulate(scene, paths=1000, seed=1, method="exact", checkpoint=path)
    edges = arrays["histogram_edges"].copy()
    edges[3] = np.nextafter(edges[3], np.inf)
    write(histogram_edges=edges)
    with pytest.raises(ValueError, match="histogram_edges of axis 0 differ"):
        crandall.simulate(scene, paths=1000, seed=1, method="exact", checkpoint=path)
    write(histogram_index=np.array([0, 5, 10, 16]))  # 16: the displacement at the stop
    with pytest.raises(ValueError, match="histogram_index"):
        crandall.simulate(scene, paths=1000, seed=1, method="exact", checkpoint=path)
    bad = {k: v for k, v in arrays.items() if k != "histogram_counts"}
    with open(path, "wb") as f:
        np.savez(f, **bad)
    with pytest.raises(ValueError, match="histogram_counts is missing"):
        crandall.simulate(scene, paths=1000, seed=1, method="exact", checkpoint=path)


def test_damaged_saved_histograms_are_refused(tmp_path):
    xr = pytest.importorskip("xarray")
    r = crandall.simulate(velocity_scene(), paths=1000, seed=1, method="exact")
    ds = r.to_xarray()
    for change, match in (
            (lambda d: d["histogram_velocity_counts"].values.__setitem__((0, 3), 2.5),
             "histogram_velocity_counts of slot 0"),
            (lambda d: d["histogram_stop_time_counts"].values.__setitem__(4, 7.0),
             "add up to"),
            (lambda d: d.__delitem__("histogram_stop_time_edges"),
             "histogram_stop_time_edges is missing")):
        bad = ds.copy(deep=True)
        change(bad)
        path = tmp_path / "bad.nc"
        bad.to_netcdf(path, engine="scipy", format="NETCDF3_64BIT")
        with pytest.raises(ValueError, match=match):
            crandall.load(path)


def test_every_histogram_brackets_its_quantity_s_mean():
    """The histograms count the values the moments average: each value lies in its bin, so the
    mean lies between the count-weighted lower and upper edges (no statistics: an exact
    bound, up to rounding), for every quantity, time and the stop, energies and peaks too."""
    scene = crandall.Scene(mu=0.3, h=1.0, t0=1.5, mass=3.0, times=[0.0, 0.5, 1.5, 2.5],
                           observe=["velocity", "displacement", "distance", "kinetic_energy",
                                    "dissipated_energy", "stop", "peaks"],
                           distributions=True)
    r = crandall.simulate(scene, paths=30_000, seed=2, dt=0.01, method="exact")
    assert set(r.distributions) == set(r.names)
    for name in r.names:
        q = crandall.quantities.quantity(name)
        for i, t in enumerate([None] if q.at_stop else r.times):
            h = r.histogram(name, t)
            cells = h.view(flow=True)
            edges = h.axes[0].edges
            assert cells[0] == 0 and cells[-1] == 0, (name, t)  # the reach holds them all
            lower = float(np.dot(cells[1:-1], edges[:-1])) / r.paths
            upper = float(np.dot(cells[1:-1], edges[1:])) / r.paths
            mean = r.mean(name) if q.at_stop else r.mean(name)[i]
            slack = 1e-12 * max(abs(lower), abs(upper), 1e-300)
            assert lower - slack <= mean <= upper + slack, (name, t, lower, mean, upper)


def test_intervals_say_whether_the_bins_limit_them():
    paths = 200_000
    coarse = crandall.Scene.scaled(tau0=2.0, times=[2.0], observe=["velocity", "stop"],
                                   distributions=["stop_time"], bins={"stop_time": 1})
    fine = crandall.Scene.scaled(tau0=2.0, times=[2.0], observe=["velocity", "stop"],
                                 distributions=["stop_time"], bins={"stop_time": 1024})
    rc = crandall.simulate(coarse, paths=paths, seed=1, method="exact")
    rf = crandall.simulate(fine, paths=paths, seed=1, method="exact")
    c, f = rc.quantile("stop_time", 0.5), rf.quantile("stop_time", 0.5)
    # One bin per octave: the interval is the median's whole bin (resolution = its widths).
    assert c.bin_limited and c.resolution >= c.high - c.low - 1e-12
    # 1024 per octave: the bins (~0.0002 wide) are far below the sampling interval (~0.003).
    assert not f.bin_limited and f.resolution < 0.2 * (f.high - f.low)
    assert f.high - f.low < c.high - c.low
    e = rf.exceedance("stop_time", 2.3)
    assert 0 < e.resolution < 0.01 and not e.bin_limited


def test_exceedances_and_quantiles_at_an_atom_match_the_analytic_atom():
    # After the switch-off a stopped body's velocity is exactly 0, with probability
    # P(stop time <= t) (analytic.velocity_atom). Its automatic bins give exact zeros a bin of
    # their own, [0, 2^-1074): the mass there was spread over the first bin [0, w), so
    # exceedance(velocity, 0) read 0.94 where P(V > 0) = 0.06 (velocity_sf(0)).
    paths = 100_000
    tau, tau0 = 1.5, 1.0
    sc = crandall.Scene.scaled(tau0=tau0, times=[tau], observe=["velocity", "kinetic_energy"],
                               distributions=["velocity", "kinetic_energy"])
    r = crandall.simulate(sc, paths=paths, seed=12, threads=2)
    atom = float(analytic.velocity_atom(tau, tau0))
    above = float(analytic.velocity_sf(0.0, tau, tau0))  # P(V > 0) = (1 - atom) / 2
    assert above == pytest.approx((1 - atom) / 2, rel=1e-9)

    def within(est, p, decided=True):  # 5 binomial standard errors: false alarm 6e-7
        assert abs(est.value - p) <= 5 * math.sqrt(p * (1 - p) / paths), (est, p)
        assert est.low <= p <= est.high
        if decided:  # the level is the atom's own value: no bin left undecided
            assert est.resolution == 0.0, est

    within(r.exceedance("velocity", 0.0, time=tau), above)              # strictly above 0
    # At or above 0 (the level just below it, in the bin [-w, 0) of a few moving paths).
    within(r.exceedance("velocity", -1e-300, time=tau), above + atom, decided=False)
    within(r.exceedance("kinetic_energy", 0.0, time=tau), 2 * above)    # moving at all
    # Every quantile inside the atom is 0 exactly, with an interval of 0 alone.
    for q in (0.5 - atom / 3, 0.5, 0.5 + atom / 3):
        est = r.quantile("velocity", q, time=tau)
        assert est.value == est.low == est.high == 0.0, (q, est)
    # A body never shaken (h = 0) is at rest: every quantile 0, nothing above 0.
    rest = crandall.Scene(mu=0.3, h=0.0, t0=1.0, times=[0.5], observe=["velocity"],
                          distributions=["velocity"])
    r0 = crandall.simulate(rest, paths=1000, seed=1)
    assert r0.quantile("velocity", 0.99, time=0.5) == (0.0, 0.0, 0.0, 0.0)
    assert r0.exceedance("velocity", 0.0, time=0.5).value == 0.0


def test_too_many_bin_edges_are_refused_when_the_scene_is_made():
    # 10^7 edges were accepted by Scene() and refused by the core at the run, without naming
    # bins. The limit is the core's own.
    assert bins.MAX_BINS == _core.MAX_HISTOGRAM_BINS
    edges = np.linspace(-1.0, 1.0, bins.MAX_BINS + 2)
    with pytest.raises(ValueError, match=r"bins\['velocity'\]: 4194305 bins, more than") as info:
        crandall.Scene.scaled(tau0=1.0, times=[1.0], distributions=["velocity"],
                              bins={"velocity": edges})
    assert info.value.name == "bins"
    crandall.Scene.scaled(tau0=1.0, times=[1.0], distributions=["velocity"],
                          bins={"velocity": edges[:-1]})  # at the limit: accepted


def test_histogram_axes_are_labelled_with_the_quantity_units_and_time():
    pytest.importorskip("boost_histogram")
    sc = crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[0.5, 1.0],
                        distributions=["velocity", "distance_at_stop"])
    r = crandall.simulate(sc, paths=500, seed=1)
    assert r.histogram("velocity", time=0.5).axes[0].label == "velocity [m/s] at t = 0.5"
    assert r.histogram("distance_at_stop").axes[0].label == "distance_at_stop [m]"

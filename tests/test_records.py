"""Recorded ground motions and Newmark's block (crandall.Record, crandall.newmark).

The external case set is pySLAMMER 0.2.2's 18 shipped records (pySLAMMER is a test dependency,
installed by the Makefile): method "slammer" must equal its numbers bit for bit, and the exact
method must meet reference values computed by an independent implementation (issue 33). The
other expected values are derived by hand (or in closed form) in the comments beside them.
"""

from __future__ import annotations

import gc
import importlib.resources
import math
import warnings

import numpy as np
import pytest

import crandall
from crandall.errors import ParameterError
from crandall.records import G, Record, load_newmark, newmark

YIELDS = (0.05, 0.1, 0.2)


@pytest.fixture(scope="module")
def pyslammer():
    return pytest.importorskip("pyslammer")


@pytest.fixture(scope="module")
def shipped(pyslammer):
    """pySLAMMER's records: {name: (its GroundMotion, our Record of the same file)}."""
    folder = importlib.resources.files("pyslammer") / "sample_ground_motions"
    out = {}
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(".csv"):
            name = entry.name[:-4]
            # pySLAMMER's reader leaves its file to the garbage collector (a ResourceWarning).
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ResourceWarning)
                theirs = pyslammer.load_sample_ground_motion(name)
                gc.collect()
            out[name] = (theirs, Record.read(str(entry)))
    assert len(out) == 18
    return out


def test_records_read_as_pyslammer_reads_them(shipped):
    for name, (gm, rec) in shipped.items():
        assert np.array_equal(rec.acceleration, gm.accel), name
        assert rec.dt == gm.dt and rec.name == name and rec.units == "g"
        assert rec.pga == pytest.approx(gm.pga, rel=1e-15)


def test_slammer_method_is_pyslammer_bit_for_bit(shipped, pyslammer):
    # 18 records x 3 yields x 2 polarities = 108 cases, in one sweep of the core.
    names = list(shipped)
    sweep = newmark([shipped[n][1] for n in names], ky=list(YIELDS), polarity="both",
                    method="slammer")
    assert sweep.dims == ("record", "yield", "polarity")
    mismatched = []
    for i, name in enumerate(names):
        gm = shipped[name][0]
        for k, ky in enumerate(YIELDS):
            for p, inverse in enumerate((False, True)):
                theirs = pyslammer.RigidAnalysis(ky, gm, inverse=inverse).max_sliding_disp
                if sweep.displacement[i, k, p] != theirs:
                    mismatched.append((name, ky, inverse, sweep.displacement[i, k, p], theirs))
    assert mismatched == []


def test_slammer_histories_and_target_pga_bit_for_bit(shipped, pyslammer):
    gm, rec = shipped["Northridge_1994_PAC-175"]
    theirs = pyslammer.RigidAnalysis(0.1, gm, target_pga=0.3, inverse=True)
    ours = newmark(rec.scaled(pga=0.3), ky=0.1, method="slammer", polarity="inverse")
    assert np.array_equal(ours.velocity, theirs.sliding_vel)
    assert np.array_equal(ours.sliding_displacement, theirs.sliding_disp)
    assert ours.displacement == theirs.max_sliding_disp
    assert rec.scaled(pga=0.3).pga == pytest.approx(0.3, rel=1e-15)


# Exact mode, one-way, normal polarity, ky = 0.1: an independent implementation's values.
REFERENCE = {
    "Imperial_Valley_1979_BCR-230": 0.5528877550295594,
    "Kobe_1995_TAK-090": 1.9423588470791866,
    "Northridge_1994_PAC-175": 0.07224120098915005,
}


def test_exact_method_meets_the_reference_values(shipped):
    for name, expected in REFERENCE.items():
        got = newmark(shipped[name][1], ky=0.1).displacement
        assert got == pytest.approx(expected, rel=1e-12, abs=0), name


def _resample(a: np.ndarray, m: int) -> np.ndarray:
    """The same straight lines through m - 1 extra points per step."""
    f = np.arange(m) / m
    return np.concatenate([(a[:-1, None] * (1 - f) + a[1:, None] * f).reshape(-1), a[-1:]])


@pytest.mark.parametrize("name", ["Imperial_Valley_1979_BCR-230", "Nisqually_2001_UNR-058"])
def test_exact_method_is_invariant_to_linear_resampling(shipped, name):
    # The exact method integrates the record joined by straight lines: points on those lines
    # change nothing but round-off (pySLAMMER's own numbers move by up to a few per cent).
    rec = shipped[name][1]
    for m in (2, 3):
        finer = Record(_resample(rec.acceleration, m), rec.dt / m)
        for kw in ({"ky": 0.1}, {"ky": 0.2}, {"mu": 0.15, "mu_static": 0.2},
                   {"kd": 0.1, "ku": 0.3}):
            coarse = newmark(rec, polarity="both", **kw)
            fine = newmark(finer, polarity="both", **kw)
            assert np.allclose(fine.displacement, coarse.displacement, rtol=1e-13, atol=1e-16), kw
            assert np.array_equal(fine.slips, coarse.slips), kw


def test_sine_pulse_error_falls_fourfold_per_halving():
    # One period of a(t) = A sin(w t), w = 2 pi / T, then rest; one-way with k = ky g < A.
    # By hand: the block starts at t1 = asin(k / A) / w; while it slides
    # W(t) = (A / w)(cos w t1 - cos w t) - k (t - t1), which returns to 0 at t2 in
    # (T/2 - t1, T) (W(T) = (A/w)(cos w t1 - 1) - k (T - t1) < 0), and
    # D = (A / w)[(t2 - t1) cos w t1 - (sin w t2 - sin w t1) / w] - k (t2 - t1)^2 / 2.
    # The record's straight lines miss the sine by O(dt^2): the error must fall 4x per halving.
    brentq = pytest.importorskip("scipy.optimize").brentq
    A, ky, T = 0.5 * G, 0.2, 1.0
    w, k = 2 * math.pi / T, ky * G
    t1 = math.asin(k / A) / w

    def W(t):
        return (A / w) * (math.cos(w * t1) - math.cos(w * t)) - k * (t - t1)

    t2 = brentq(W, T / 2 - t1, T, xtol=1e-16, rtol=1e-15)
    exact = (A / w) * ((t2 - t1) * math.cos(w * t1) - (math.sin(w * t2) - math.sin(w * t1)) / w) \
        - k * (t2 - t1) ** 2 / 2
    errors = []
    for n in (100, 200, 400, 800, 1600):
        i = np.arange(2 * n + 1)
        record = np.where(i <= n, A * np.sin(w * i / n), 0.0)
        r = newmark(record, dt=T / n, units="m/s2", ky=ky)
        errors.append(r.displacement - exact)
        assert r.events[0, 0] == pytest.approx(t1, abs=(T / n) ** 2)
        assert r.events[0, 1] == pytest.approx(t2, abs=(T / n) ** 2)
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(np.abs(ratios - 4) < 0.03), ratios


def test_one_way_equals_the_incline_whose_upslope_yield_exceeds_the_pga(shipped):
    for name in ("Imperial_Valley_1979_BCR-230", "Kobe_1995_TAK-090", "Coalinga_1983_PVB-045"):
        rec = shipped[name][1]
        one = newmark(rec, ky=list(YIELDS), polarity="both")
        incline = newmark(rec, kd=list(YIELDS), ku=1.01 * rec.pga, polarity="both")
        assert np.array_equal(one.displacement, incline.displacement), name
        assert np.array_equal(one.slips, incline.slips), name
        # ...and a smaller ku does slide upslope on these records.
        low = newmark(rec, kd=0.1, ku=0.1)
        assert low.min_displacement < 0 < low.max_displacement


def test_flat_is_the_incline_with_equal_yields_seen_from_the_body(shipped):
    rec = shipped["Loma_Prieta_1989_HSP-000"][1]
    flat = newmark(rec, mu=0.12)
    incline = newmark(rec, kd=0.12, ku=0.12)
    assert flat.displacement == -incline.displacement
    assert flat.max_displacement == -incline.min_displacement
    assert np.array_equal(flat.velocity, -incline.velocity)


MU1 = 1.0 / G   # a yield of 1 m/s^2 (to round-off)


def test_two_way_flat_by_hand():
    # a = 2, 2, 0, 0, 0, 0 m/s^2 (dt = 1 s), mu g = 1: W = -V (W' = a - 1 while W > 0) rises
    # to 1 at t = 1 (D 1/2), follows 1 + s - s^2 on [1, 2] (D 7/6), then 1 - s: stops at
    # t = 3 (D 1/2). The body's displacement relative to the foundation is -13/6.
    r = newmark([2, 2, 0, 0, 0, 0], dt=1.0, units="m/s2", mu=MU1)
    assert r.displacement == pytest.approx(-13 / 6, rel=1e-14)
    assert r.min_displacement == pytest.approx(-13 / 6, rel=1e-14) and r.max_displacement == 0
    assert r.slips == 1
    assert np.allclose(r.events, [[0.0, 3.0, -1.0, 1.0]], rtol=1e-14, atol=0)
    assert r.velocity[:3] == pytest.approx([0, -1, -1], rel=1e-14)
    # With mu_static g = 1.5 on a = 0, 3, 3, 0, ...: the onset is at t = 0.5 where a crosses
    # 1.5, with W' = 1.5 - 1 = 0.5 exactly; W(t) = 1.5 (t^2 - 1/4) - (t - 1/2) gives W(1) =
    # 5/8, D(1) = 1/8; W' = 2 on [1, 2]: W 21/8, D + 13/8; W' = 2 - 3s on [2, 3]: W 25/8,
    # D + 25/8; then W' = -1: stop at 3 + 25/8, D + (25/8)^2 / 2. Total 9.7578125.
    r = newmark([0, 3, 3, 0, 0, 0, 0, 0, 0], dt=1.0, units="m/s2", mu=MU1, mu_static=1.5 * MU1)
    assert r.displacement == pytest.approx(-9.7578125, rel=1e-13)
    assert r.events[0, :2] == pytest.approx([0.5, 6.125], rel=1e-13)


def test_incline_upslope_by_hand():
    # a = 0, -4, -4, 0, 0, 0, 0 m/s^2 (dt 1 s), kd g = 1, ku g = 2: upslope from t = 0.5
    # (a = -2) with W' = a + 2 = 2 - 4t: W(1) = -1/2, D -1/12; W' = -2 on [1, 2]: W -5/2,
    # D -3/2; W' = -2 + 4s on [2, 3]: W -5/2, D -17/6; then W' = +2: stop at 4.25, D -25/16.
    r = newmark([0, -4, -4, 0, 0, 0, 0], dt=1.0, units="m/s2", kd=MU1, ku=2 * MU1)
    assert r.displacement == pytest.approx(-287 / 48, rel=1e-13)
    assert np.allclose(r.events, [[0.5, 4.25, -1.0, 1.0]], rtol=1e-13, atol=0)
    # Slope and friction: kd = mu cos - sin, ku = mu cos + sin; the reverse record slides
    # down by the same amount on the mirrored incline.
    m = newmark([0, 4, 4, 0, 0, 0, 0], dt=1.0, units="m/s2", kd=2 * MU1, ku=MU1)
    assert m.displacement == pytest.approx(287 / 48, rel=1e-13)


def test_a_slide_still_going_at_the_end_is_reported_so():
    r = newmark([2.0, 2.0], dt=1.0, units="m/s2", ky=MU1)
    assert r.displacement == pytest.approx(0.5, rel=1e-14)
    assert np.array_equal(r.events, [[0.0, 1.0, 1.0, 0.0]])


def test_sweep_shapes_and_threads(shipped):
    recs = [shipped[n][1] for n in list(shipped)[:4]]
    ky = np.linspace(0.02, 0.3, 7)
    one = newmark(recs, ky=ky, polarity="both", threads=1)
    two = newmark(recs, ky=ky, polarity="both", threads=2)
    assert np.array_equal(one.table, two.table)
    assert one.displacement.shape == (4, 7, 2)
    # Each case alone is the same number.
    alone = newmark(recs[2], ky=float(ky[3]), polarity="inverse")
    assert alone.displacement == one.displacement[2, 3, 1]
    assert newmark(recs[0], ky=ky).displacement.shape == (7,)
    # A larger yield never slides further (one-way): displacements fall with ky.
    assert np.all(np.diff(one.displacement, axis=1) <= 0)


def test_results_keep(tmp_path, shipped):
    pytest.importorskip("xarray")
    rec = shipped["Kobe_1995_TAK-090"][1]
    one = newmark(rec, ky=0.1)
    many = newmark([rec, shipped["Duzce_1999_375-090"][1]], kd=[0.1, 0.2], ku=0.3,
                   polarity="both")
    for r in (one, many):
        path = tmp_path / "r.nc"
        r.save(path)
        back = load_newmark(path)
        assert np.array_equal(back.table, r.table) and back.dims == r.dims
        assert back.mode == r.mode and back.records == r.records
        for k in r.yields:
            assert np.array_equal(back.yields[k], r.yields[k])
        with pytest.raises(ValueError, match="load_newmark"):
            crandall.load(path)
    back = load_newmark(tmp_path / "r.nc")
    assert back.displacement.shape == (2, 2, 2)
    one.save(tmp_path / "one.nc")
    back = load_newmark(tmp_path / "one.nc")
    assert np.array_equal(back.velocity, one.velocity) and np.array_equal(back.events, one.events)
    ds = one.to_xarray()
    assert float(ds["displacement"].squeeze()) == one.displacement
    assert ds["velocity"].dims == ("time",)
    page = one._repr_html_()
    assert "Kobe_1995_TAK-090" in page and f"{one.displacement:.6g}" in page
    with pytest.raises(ValueError, match="sweep keeps no histories"):
        many.velocity


def test_reading_files(tmp_path):
    at2 = tmp_path / "RSN1_TEST.AT2"
    at2.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nTEST 1999, STATION, 090\n"
                   "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS=    7, DT=   .0100 SEC\n"
                   "  .1000000E-01  .2000000E-01 -.3000000E-01  .4000000E+00\n"
                   "  .5000000E-01 -.6000000E-01  .7000000E-01\n")
    r = Record.read(at2)
    assert r.dt == 0.01 and r.npts == 7 and r.name == "RSN1_TEST"
    assert r.acceleration.tolist() == [0.01, 0.02, -0.03, 0.4, 0.05, -0.06, 0.07]
    assert r.pga == pytest.approx(0.4)
    older = tmp_path / "older.at2"   # the older PEER header: "NPTS DT NPTS, DT" on line 4
    older.write_text(at2.read_text().replace("NPTS=    7, DT=   .0100 SEC", "    7   .0100   NPTS, DT"))
    assert Record.read(older) == Record(r.acceleration, 0.01, name="older")
    older.write_text("x\ny\nz\nw\n1\n")
    with pytest.raises(ParameterError, match="not a PEER NGA AT2 file"):
        Record.read(older)
    one = tmp_path / "one.txt"
    one.write_text("# cm/s2\n1.0\n-2.0\n3.5\n")
    r = Record.read(one, dt=0.02, units="cm/s2")
    assert r.si().tolist() == pytest.approx([0.01, -0.02, 0.035])
    with pytest.raises(ParameterError) as e:
        Record.read(one)
    assert e.value.name == "dt"
    uneven = tmp_path / "uneven.csv"
    uneven.write_text("0.0,0.1\n0.01,0.2\n0.03,0.1\n")
    with pytest.raises(ParameterError, match="evenly"):
        Record.read(uneven)
    bad = tmp_path / "short.AT2"
    bad.write_text(at2.read_text().replace("NPTS=    7", "NPTS=    8"))
    with pytest.raises(ParameterError, match="NPTS=8"):
        Record.read(bad)
    assert Record([1, 2], 0.01).scaled(3.0).acceleration.tolist() == [3.0, 6.0]
    assert Record([0.1, -0.2], 0.01).scaled(pga=0.5).acceleration.tolist() == \
        pytest.approx([0.25, -0.5])


REC = [0.0, 0.3, -0.2, 0.1]


@pytest.mark.parametrize("call, name", [
    (lambda: newmark(REC, dt=0.01, ky=-0.1), "ky"),
    (lambda: newmark(REC, dt=0.01, ky=float("nan")), "ky"),
    (lambda: newmark(REC, dt=0.01, ky=float("inf")), "ky"),
    (lambda: newmark(REC, dt=0.01, ky=[0.1, 0.0]), "ky"),
    (lambda: newmark(REC, dt=0.01, ky="0.1"), "ky"),
    (lambda: newmark(REC, dt=0.01), "ky"),
    (lambda: newmark(REC, dt=0.01, ky=0.1, mu=0.1), "ky, mu"),
    (lambda: newmark(REC, dt=0.01, mu=0.2, mu_static=0.1), "mu_static"),
    (lambda: newmark(REC, dt=0.01, ky=0.1, mu_static=0.2), "mu_static"),
    (lambda: newmark(REC, dt=0.01, kd=0.1), "ku"),
    (lambda: newmark(REC, dt=0.01, kd=0.0, ku=0.1), "kd"),
    (lambda: newmark(REC, dt=0.01, kd=[0.1, 0.2], ku=[0.1, 0.2, 0.3]), "kd, ku"),
    (lambda: newmark(REC, dt=0.0, ky=0.1), "dt"),
    (lambda: newmark(REC, dt=-0.01, ky=0.1), "dt"),
    (lambda: newmark(REC, ky=0.1), "dt"),
    (lambda: newmark([0.0, float("nan"), 0.1], dt=0.01, ky=0.1), "acceleration"),
    (lambda: newmark([0.0, float("inf")], dt=0.01, ky=0.1), "acceleration"),
    (lambda: newmark([0.1], dt=0.01, ky=0.1), "acceleration"),
    (lambda: newmark(REC, dt=0.01, ky=0.1, units="ft/s2"), "units"),
    (lambda: newmark(REC, dt=0.01, ky=0.1, method="rk4"), "method"),
    (lambda: newmark(REC, dt=0.01, ky=0.1, polarity="up"), "polarity"),
    (lambda: newmark(REC, dt=0.01, mu=0.1, method="slammer"), "method"),
    (lambda: newmark(REC, dt=0.01, ky=0.1, threads=0), "threads"),
    (lambda: newmark(Record(REC, 0.01), dt=0.01, ky=0.1), "dt"),
    (lambda: newmark([1e300, -1e300, 1e300], dt=1e10, units="m/s2", ky=0.1), "record"),
    (lambda: Record(REC, 0.01).scaled(pga=-1), "pga"),
    (lambda: Record([0.0, 0.0], 0.01).scaled(pga=0.3), "pga"),
    (lambda: Record(REC, 0.01, scale=float("nan")), "scale"),
    (lambda: crandall.Scene(mu=0.1, ky=0.1, h=1.0, t0=1.0, times=[1.0]), "mu, ky"),
    (lambda: crandall.Scene(h=1.0, t0=1.0, times=[1.0]), "mu"),
    (lambda: crandall.Scene(ky=-0.1, h=1.0, t0=1.0, times=[1.0]), "ky"),
])
def test_bad_input_names_the_parameter(call, name):
    with pytest.raises(ParameterError) as e:
        call()
    assert e.value.name == name
    assert name.split(",")[0] in str(e.value)


def test_ky_on_a_white_noise_scene_is_mu():
    a = crandall.Scene(ky=0.1, h=1.0, t0=2.0, g=G, times=[1.0, 2.0])
    b = crandall.Scene(mu=0.1, h=1.0, t0=2.0, g=G, times=[1.0, 2.0])
    assert a.to_dict() == b.to_dict()
    ra = crandall.simulate(a, paths=2000, seed=5)
    rb = crandall.simulate(b, paths=2000, seed=5)
    assert np.array_equal(ra.mean("distance"), rb.mean("distance"))


def test_records_sampled_from_white_noise_converge_to_the_distance():
    # Under white noise of intensity h the one-way block's W is a Brownian motion with drift
    # -ky g reflected at 0: in law, the speed |V| of crandall's body with mu = ky, so that
    # E D(t) = E S(t), the analytic mean distance (docs/records.md). A record of independent
    # samples a_i = h z_i / sqrt(dt) joined by straight lines approaches it with an error
    # ~ c sqrt(dt) (the reflection's discretisation; c about -1.4 m s^-1/2 here, measured), so
    # the extrapolation 2 D(dt/4) - D(dt) from two records of one Brownian path (the coarse
    # samples are the means of four fine ones) must hit 2 E S(T_fine) - E S(T_coarse) within
    # 4 standard errors of its R = 6000 values (one standard error is about 0.006 m, or 0.7 %;
    # the fine record alone misses by about 8). Fixed seed.
    analytic = pytest.importorskip("crandall.analytic")
    h, k = 1.0, 1.0                 # m s^-3/2; ky g = 1 m/s^2
    ky = k / G
    R, M, coarse = 6000, 500, 0.004
    fine = coarse / 4
    z = np.random.default_rng(20261126).standard_normal((R, 4 * M))
    af = h * z / math.sqrt(fine)
    ac = h * z.reshape(R, M, 4).sum(axis=2) / (4 * math.sqrt(fine))
    df = newmark([Record(r, fine, units="m/s2") for r in af], ky=ky).displacement
    dc = newmark([Record(r, coarse, units="m/s2") for r in ac], ky=ky).displacement
    e_f = analytic.physical("distance_mean", (4 * M - 1) * fine, mu=ky, h=h, g=G)
    e_c = analytic.physical("distance_mean", (M - 1) * coarse, mu=ky, h=h, g=G)
    x = 2 * df - dc
    se = x.std(ddof=1) / math.sqrt(R)
    assert abs(x.mean() - (2 * e_f - e_c)) < 4 * se, (x.mean(), 2 * e_f - e_c, se)
    # The test can fail: without the extrapolation the fine records alone are far off.
    assert abs(df.mean() - e_f) > 4 * df.std(ddof=1) / math.sqrt(R)


def test_command_line(tmp_path, capsys, shipped):
    from crandall.cli import main

    path = tmp_path / "rec.csv"
    rec = shipped["Imperial_Valley_1979_BCR-230"][1]
    np.savetxt(path, np.column_stack([rec.time, rec.acceleration]), delimiter=",",
               header="Time (s),Acceleration (g's)")
    assert main(["newmark", str(path), "--ky", "0.1", "--polarity", "both",
                 "--save", str(tmp_path / "r.nc")]) == 0
    out = capsys.readouterr().out
    assert f"{REFERENCE['Imperial_Valley_1979_BCR-230']:.6g}" in out and "inverse" in out
    assert load_newmark(tmp_path / "r.nc").displacement.shape == (2,)
    pytest.importorskip("matplotlib")
    assert main(["newmark", str(path), "--ky", "0.1", "--method", "slammer",
                 "--figure", str(tmp_path / "f.png")]) == 0
    assert (tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"
    assert main(["newmark", str(path), "--mu", "-0.1"]) == 2
    assert "mu must be finite and > 0" in capsys.readouterr().err
    assert main(["newmark", str(path), "--ky", "0.1", "0.2", "--figure",
                 str(tmp_path / "g.png")]) == 2


def test_figures(shipped):
    pytest.importorskip("matplotlib")
    from crandall import plots

    rec = shipped["Kobe_1995_TAK-090"][1]
    fig = plots.newmark(newmark(rec, kd=0.1, ku=0.2, polarity="inverse"))
    assert len(fig.axes) == 3
    assert "Kobe_1995_TAK-090" in fig._suptitle.get_text()
    assert "PGA 0.616 g" in fig._suptitle.get_text() and "kd = 0.1 g" in fig._suptitle.get_text()
    fig = plots.newmark_sweep(newmark([rec], ky=[0.05, 0.1, 0.2], polarity="both"))
    assert len(fig.axes[0].lines) == 2
    with pytest.raises(ValueError, match="one case"):
        plots.newmark(newmark(rec, ky=[0.1, 0.2]))


# -- fragility over a suite of records (crandall.record_fragility) --------------------------

def _constant_suite():
    # A record of constant acceleration A (g) for 1 s: one-way with yield ky < A the block
    # slides from t = 0 with W = (A - ky) g t, so D = (A - ky) g / 2 at the end (by hand);
    # A <= ky, or the inverse polarity (-A), never slides: D = 0.
    return [Record(np.full(101, a), 0.01, name=f"constant {a}") for a in (0.05, 0.2, 0.3, 0.5)]


def test_record_fragility_is_the_weighted_fraction_by_hand():
    suite, w = _constant_suite(), [1.0, 2.0, 3.0, 4.0]
    r = crandall.record_fragility(suite, [0.25, 0.75, 1.5], ky=[0.1, 0.25], weights=w)
    assert (r.axis, r.by, r.quantity, r.polarities) == ("ky", None, "displacement",
                                                        ("normal", "inverse"))
    exact = np.array([[max(a - ky, 0) * G / 2 for ky in (0.1, 0.25)] for a in (0.05, 0.2, 0.3, 0.5)])
    assert np.allclose(r.displacement[..., 0], exact, rtol=1e-13, atol=0)
    assert (r.displacement[..., 1] == 0).all()
    # ky = 0.1: D = 0, 0.49, 0.98, 1.96 m; each record exceeds in its normal polarity only,
    # so counts 1/2: (2 + 3 + 4) / 10 / 2, (3 + 4) / 10 / 2, 4 / 10 / 2. ky = 0.25: D = 0, 0,
    # 0.245, 1.23 m.
    by_hand = np.array([[0.45, 0.35, 0.2], [0.2, 0.2, 0.0]])
    assert np.allclose(r.probability, by_hand, rtol=1e-14, atol=1e-15)
    assert r.n_eff == pytest.approx(100 / 30, rel=1e-14)       # (sum w)^2 / sum w^2
    assert np.allclose(r.stderr, np.sqrt(by_hand * (1 - by_hand) / (100 / 30)), rtol=1e-12)
    assert (r.low <= r.probability).all() and (r.probability <= r.high).all()
    assert r.low[1, 2] == 0 and 0 < r.high[1, 2] < 1
    # Scaled to a PGA, every constant record is the same A: all or none exceed, and one
    # polarity: the fraction is 0 or 1 exactly where (pga - ky) g / 2 > d.
    s = crandall.record_fragility(suite, [0.25, 0.75], ky=[0.1, 0.2], pga=[0.3, 0.6],
                                  polarity="normal")
    assert (s.axis, s.by, s.probability.shape) == ("pga", "ky", (2, 2, 2))
    want = np.array([[[(p - k) * G / 2 > d for d in (0.25, 0.75)] for k in (0.1, 0.2)]
                     for p in (0.3, 0.6)], dtype=float)
    assert np.array_equal(s.probability, want)
    assert np.array_equal(s.section(1).probability, want[:, 1])


def test_record_fragility_of_the_reference_records(shipped):
    # The independent implementation's displacements (REFERENCE, ky 0.1, normal polarity):
    # 0.553, 1.942, 0.0722 m; weights 1, 2, 3 of 6.
    names = list(REFERENCE)
    r = crandall.record_fragility([shipped[n][1] for n in names], [0.05, 0.1, 1.0, 2.0],
                                  ky=0.1, weights=[1, 2, 3], polarity="normal")
    assert np.allclose(r.displacement[:, 0, 0], [REFERENCE[n] for n in names], rtol=1e-12)
    assert np.allclose(r.probability[0], [1.0, 3 / 6, 2 / 6, 0.0], rtol=1e-14, atol=1e-15)


def test_the_weighted_interval_covers_at_least_95_percent_for_equal_weights():
    # Equal weights: n_eff = n, x = k of n, the Clopper-Pearson interval. Its coverage at a true
    # fraction q is sum_k Binomial(n, q)(k) [low(k) <= q <= high(k)], computed exactly here:
    # at least 0.95 at every q (the interval's guarantee), and not wasteful where n allows it
    # (below 0.99 at q = 0.5 for n >= 18; with 4 records every interval holds 0.5).
    from scipy.stats import binom
    from crandall.suites import effective_size, weighted_interval
    for n in (4, 18, 50):
        assert effective_size(np.full(n, 0.37)) == pytest.approx(n, rel=1e-13)
        k = np.arange(n + 1)
        low, high = weighted_interval(k / n, n)
        for q in np.linspace(0.001, 0.999, 499):
            cover = float(np.sum(binom.pmf(k, n, q) * ((low <= q) & (q <= high))))
            assert cover >= 0.95 - 1e-12, (n, q, cover)
        mid = float(np.sum(binom.pmf(k, n, 0.5) * ((low <= 0.5) & (0.5 <= high))))
        assert n < 18 or mid < 0.99, (n, mid)


def test_the_weighted_interval_coverage_with_unequal_weights_by_enumeration():
    # Unequal weights: the weighted fraction is not a binomial count, and Clopper-Pearson on
    # Kish's n_eff is an approximation. Its coverage when each of 12 records exceeds
    # independently with probability q, computed exactly over the 2^12 outcomes at 199 values
    # of q: at least 0.95 for spread weights (lognormal with log-sd 0.5 and 1, linear 1..12, one
    # record with a tenth of the weight; 0.959-0.978 here); with one record holding half the
    # weight (n_eff 3.7) it falls to 0.945 near q = 0.055 (docs/records.md: measured, not
    # guaranteed; bench/records_coverage.py simulates larger suites and both polarities).
    import itertools
    from crandall.suites import effective_size, weighted_interval
    n = 12
    outcomes = np.array(list(itertools.product([0.0, 1.0], repeat=n)))
    k = outcomes.sum(axis=1)
    rng = np.random.default_rng(1)
    patterns = {"lognormal 0.5": rng.lognormal(0.0, 0.5, n), "lognormal 1": rng.lognormal(0.0, 1.0, n),
                "linear": np.arange(1.0, n + 1), "a tenth": np.r_[(n - 1) / 9, np.ones(n - 1)],
                "a half": np.r_[n - 1.0, np.ones(n - 1)]}
    lowest = {}
    for name, w in patterns.items():
        fraction = np.clip(outcomes @ (w / w.sum()), 0.0, 1.0)
        low, high = weighted_interval(fraction, effective_size(w))
        lowest[name] = min(float(np.sum(q ** k * (1 - q) ** (n - k) * ((low <= q) & (q <= high))))
                           for q in np.linspace(0.005, 0.995, 199))
    assert all(lowest[name] >= 0.95 for name in patterns if name != "a half"), lowest
    assert 0.94 < lowest["a half"] < 0.95, lowest


def test_record_fragility_fit_files_figure_and_refusals(tmp_path, shipped):
    pytest.importorskip("xarray")
    suite = [rec for _, rec in shipped.values()]
    r = crandall.record_fragility(suite, [0.05, 0.2], ky=[0.05, 0.1], pga=np.geomspace(0.1, 1, 8))
    fits = r.fit_lognormal()
    assert len(fits) == 2 and np.isfinite(fits[0].median).all()
    # The fit reproduces a lognormal curve it is given exactly (fractions = Phi, n_eff 18).
    from scipy.special import ndtr
    sec = r.section(0)
    sec.probability = ndtr(np.log(sec.values / 0.4) / 0.5)[:, None] * np.ones((1, 2))
    exact = sec.fit_lognormal()
    assert exact.median[0] == pytest.approx(0.4, rel=1e-6)
    assert exact.beta[0] == pytest.approx(0.5, rel=1e-6)
    path = tmp_path / "suite.nc"
    r.save(path)
    back = crandall.FragilityResult.load(path)
    assert type(back) is crandall.RecordFragilityResult
    for name in ("values", "by_values", "thresholds", "probability", "low", "high",
                 "displacement", "weights", "record_pga"):
        assert np.array_equal(getattr(back, name), getattr(r, name)), name
    assert back.records == r.records and back.yields == r.yields and back.by == "ky"
    assert "Clopper-Pearson" in str(r) and "ky = 0.1" in r._repr_html_()
    pytest.importorskip("matplotlib")
    from crandall import plots
    # The stochastic model over mu (g = 9.80665: mu is ky) and the suite over ky on one panel.
    over_ky = crandall.record_fragility(suite, [0.05, 0.2], ky=np.geomspace(0.02, 0.3, 6))
    p = ndtr(np.log(0.1 / np.geomspace(0.02, 0.3, 6)) / 0.6)[:, None] * np.ones((1, 2))
    model = crandall.FragilityResult(quantity="distance_at_stop", axis="mu",
                                     values=np.geomspace(0.02, 0.3, 6), thresholds=[0.05, 0.2],
                                     probability=p, stderr=0.05 * p, low=0.9 * p, high=1.1 * p,
                                     reliable=np.ones(p.shape, bool), units="m")
    fig = plots.fragility(model, records=over_ky)
    assert len(fig.axes) == 1 and any("records" in t.get_text()
                                      for t in fig.axes[0].get_legend().get_texts())
    model.axis = "intensity"   # P growing with h
    for name in ("probability", "stderr", "low", "high"):
        setattr(model, name, getattr(model, name)[::-1].copy())
    assert len(plots.fragility(model, records=sec).axes) == 2   # PGA along the top
    for call, name in [(dict(records=[]), "records"), (dict(weights=[1.0]), "weights"),
                       (dict(weights=[-1.0] + [1.0] * 17), "weights"),
                       (dict(thresholds=[0.0]), "thresholds"), (dict(pga=[0.0]), "pga"),
                       (dict(measure="peak"), "measure"), (dict(ky=None), "ky"),
                       (dict(polarity="up"), "polarity")]:
        args = dict(records=suite, thresholds=[0.1], ky=0.1)
        args.update(call)
        with pytest.raises(ParameterError) as info:
            crandall.record_fragility(**args)
        assert info.value.name == name, (call, info.value)


def test_crandall_suite_prints_the_fractions_by_hand_and_writes_its_files(tmp_path, capsys):
    # The constant records above as one-column files (dt given): ky 0.1 and 0.25, weights
    # 1..4, both polarities: the fractions by hand of test_record_fragility_is_the_weighted_
    # fraction_by_hand, printed, saved and drawn.
    from crandall.cli import main
    from crandall.fragility import load as load_fragility
    files = []
    for rec in _constant_suite():
        path = tmp_path / f"{rec.name.replace(' ', '_')}.txt"
        path.write_text("\n".join(repr(float(x)) for x in rec.acceleration) + "\n")
        files.append(str(path))
    out = tmp_path / "suite.nc"
    argv = ["suite", *files, "--dt", "0.01", "--thresholds", "0.25,0.75,1.5", "--ky", "0.1",
            "0.25", "--weights", "1,2,3,4", "--save", str(out)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "Clopper-Pearson" in text and "lognormal fit per threshold" in text
    back = load_fragility(out)
    assert type(back) is crandall.RecordFragilityResult
    assert np.allclose(back.probability, [[0.45, 0.35, 0.2], [0.2, 0.2, 0.0]], rtol=1e-14,
                       atol=1e-15)
    # Refusals name the option, with the exit status 2 and no traceback.
    assert main(argv[:-2] + ["--weights", "1,2"]) == 2
    assert "--weights: 2 weights for 4 records" in capsys.readouterr().err
    assert main(argv[:-4] + ["--model", str(out)]) == 2
    assert "--model draws a stochastic fragility" in capsys.readouterr().err
    pytest.importorskip("matplotlib")
    figure = tmp_path / "suite.png"
    assert main(argv[:-2] + ["--figure", str(figure)]) == 0
    assert figure.stat().st_size > 1000
    # Beside a saved stochastic fragility over mu (mu and ky in g are one number).
    mu = np.geomspace(0.05, 0.3, 4)
    p = np.linspace(0.6, 0.1, 4)[:, None] * np.ones((1, 3))
    model = crandall.FragilityResult(quantity="distance_at_stop", axis="mu", values=mu,
                                     thresholds=[0.25, 0.75, 1.5], probability=p,
                                     stderr=0.05 * p, low=0.9 * p, high=1.1 * p,
                                     reliable=np.ones(p.shape, bool), units="m")
    model.save(tmp_path / "model.nc")
    both = tmp_path / "both.png"
    assert main(argv[:-2] + ["--model", str(tmp_path / "model.nc"), "--figure", str(both)]) == 0
    assert both.stat().st_size > 1000

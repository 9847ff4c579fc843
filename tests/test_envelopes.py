"""crandall.envelopes: smooth envelopes as piecewise schedules that keep the mean h^2 on each
piece (so the noise's energy), and the intensity from a power spectral density."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import integrate

import crandall
from crandall import envelopes, model


def _energy(h, t0):
    return sum(x * x * (e - s) for x, s, e in zip(h, [0.0] + t0[:-1], t0))


def test_each_piece_keeps_the_envelope_energy():
    h, t0 = envelopes.amin_ang(1.2, t1=2.0, t2=6.0, c=0.5, pieces=16)
    assert t0[-1] == pytest.approx(6.0 + math.log(1e4) / 0.5) and 2.0 in t0 and 6.0 in t0
    # int h(t)^2 dt of the envelope itself, in closed form: h^2 (t1 / 3 + (t2 - t1) +
    # (1 - e^{-c (end - t2)}) / c).
    end = t0[-1]
    want = 1.44 * (2.0 / 3 + 4.0 + (1 - math.exp(-0.5 * (end - 6.0))) / 0.5)
    assert _energy(h, t0) == pytest.approx(want, rel=1e-10)
    # The strong phase is flat: its pieces have the strong intensity exactly.
    strong = [x for x, s, e in zip(h, [0.0] + t0[:-1], t0) if 2.0 <= s and e <= 6.0]
    assert strong and np.allclose(strong, 1.2, rtol=1e-12)
    # Jennings: the amplitude is (t/t1)^2 while building up, so h^2 goes as (t/t1)^4.
    hj, tj = envelopes.jennings(1.0, t1=1.0, t2=2.0, c=1.0, end=4.0, pieces=8)
    assert _energy(hj, tj) == pytest.approx(1 / 5 + 1.0 + (1 - math.exp(-4.0)) / 2, rel=1e-10)


def test_shinozuka_sato_peaks_at_one_and_a_scene_takes_the_schedule():
    h, t0 = envelopes.shinozuka_sato(0.8, a=0.2, b=1.0, pieces=24)
    peak_t = math.log(5.0) / 0.8
    assert peak_t in t0 and max(h) <= 0.8 + 1e-12 and max(h) > 0.75
    f = lambda t: (0.8 * (math.exp(-0.2 * t) - math.exp(-t)) / (
        math.exp(-0.2 * peak_t) - math.exp(-peak_t))) ** 2
    assert _energy(h, t0) == pytest.approx(integrate.quad(f, 0, t0[-1], limit=200)[0], rel=1e-9)
    sc = crandall.Scene(mu=0.3, h=h, t0=t0, times=[5.0, 10.0])
    assert model.noise_energy(sc, sc.t0) == pytest.approx(_energy(h, t0), rel=1e-12)


def test_any_piece_count_keeps_the_energy():
    # With 8 or 16 pieces the schedule's energy is the envelope's (each piece keeps it).
    h8, t8 = envelopes.from_function(lambda t: math.sin(t) ** 2, math.pi, pieces=8)
    h16, t16 = envelopes.from_function(lambda t: math.sin(t) ** 2, math.pi, pieces=16)
    assert _energy(h8, t8) == pytest.approx(_energy(h16, t16), rel=1e-10)
    assert _energy(h8, t8) == pytest.approx(3 * math.pi / 8, rel=1e-10)  # int sin^4


@pytest.mark.parametrize("call, match", [
    (lambda: envelopes.amin_ang(1.0, t1=3.0, t2=2.0, c=1.0), "t2 must be >= t1"),
    (lambda: envelopes.amin_ang(-1.0, t1=1.0, t2=2.0, c=1.0), "h must be finite and >= 0"),
    (lambda: envelopes.shinozuka_sato(1.0, a=1.0, b=0.5), "b must be > a"),
    (lambda: envelopes.from_function(lambda t: -1.0, 1.0), r"h\(0\) = -1.0"),
    (lambda: envelopes.from_function(lambda t: 1.0, 1.0, pieces=0), "pieces must be"),
    (lambda: envelopes.intensity_from_psd(1.0, sided="both"), "sided must be"),
    (lambda: envelopes.intensity_from_psd(math.nan), "psd must be finite"),
])
def test_bad_arguments_are_named(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_intensity_from_psd_conventions():
    # Two-sided S0: h^2 = 2 pi S0; one-sided G0 = 2 S0 gives the same h.
    assert envelopes.intensity_from_psd(0.01) ** 2 == pytest.approx(2 * math.pi * 0.01)
    assert envelopes.intensity_from_psd(0.02, sided="one") == pytest.approx(
        envelopes.intensity_from_psd(0.01, sided="two"), rel=1e-15)


# -- what from_function refuses and what it warns about (issue 30, findings 8 and 9) ---------

def _negative_between_the_checked_points(t):
    # Negative on (0.26, 0.30) of [0, 1]: between the 17 evenly spaced points checked, where
    # the quadrature's first rule has a point (0.2833).
    return -1.0 if 0.26 < t < 0.30 else 1.0


@pytest.mark.parametrize("h, match", [
    (lambda t: 1j, r"h\(0\) = 1j: an intensity is a real number.*complex"),
    (lambda t: None, r"h\(0\) = None: an intensity is a real number"),
    (lambda t: "1", r"h\(0\) = '1': an intensity is a real number.*str"),
    (lambda t: t < 1, r"h\(0\) = True: an intensity is a real number.*bool"),
    (lambda t: math.nan, r"h\(0\) = nan: an intensity is finite and >= 0"),
    (lambda t: math.inf if t > 0.5 else 1.0, r"h\(0.5625\) = inf"),
    (_negative_between_the_checked_points, r"h\(0.2833\d*\) = -1.0"),
    (lambda t: 1e200, "h: its square does not integrate to a finite value"),
])
def test_a_bad_function_is_refused_naming_h(h, match):
    with pytest.raises(crandall.scene.ParameterError, match=match) as info:
        envelopes.from_function(h, 1.0, pieces=1)
    assert info.value.name == "h"


def test_intensity_from_psd_does_not_overflow():
    # h = sqrt(2 pi S0) is a double for every finite S0 (at most 3.4e154): 2 pi S0 itself
    # overflows for S0 > 2.9e307, which gave inf.
    assert envelopes.intensity_from_psd(1e308) == pytest.approx(math.sqrt(2 * math.pi) * 1e154,
                                                                rel=1e-15)
    top = envelopes.intensity_from_psd(1.7976931348623157e308, sided="one")
    assert math.isfinite(top) and top == pytest.approx(math.sqrt(math.pi / 4 * 1.7976931348623157e308) * 2, rel=1e-15)


def _pulse(t):
    # 1 ms of shaking at 0.5 s: between the points from_function samples with 4 pieces on
    # [0, 2] (the nearest, 0.5011, is the first rule's on [0.5, 1]).
    return 1.0 if 0.5 < t < 0.501 else 0.0


def test_a_missed_pulse_warns_and_breaks_find_it():
    with pytest.warns(envelopes.EnvelopeWarning, match=r"0 at every one of the \d+ points"
                      r".*breaks=") as record:
        env = envelopes.from_function(_pulse, 2.0, pieces=4)
    assert len(record) == 1 and env.h == [0.0] * 4
    # Its start and end as breaks: a piece of its own, with its energy.
    h, t0 = envelopes.from_function(_pulse, 2.0, pieces=4, breaks=[0.5, 0.501])
    assert _energy(h, t0) == pytest.approx(1e-3, rel=1e-9)


def test_a_pulse_seen_at_a_checked_point_but_missed_by_its_piece_warns():
    # h(0.125) = 1 (one of the 17 points checked) on a 0.2 ms pulse that the quadrature of
    # its piece [0, 0.5] steps over: the piece would be 0 with the function plainly not.
    with pytest.warns(envelopes.EnvelopeWarning, match=r"h\(0.125\) = 1.0 .*\[0, 0.5\]"):
        envelopes.from_function(lambda t: 1.0 if abs(t - 0.125) < 1e-4 else 0.0, 2.0,
                                pieces=4)


def test_a_function_with_energy_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        envelopes.from_function(lambda t: 1.0 if t < 1.0 else 0.0, 3.0, pieces=3)
        envelopes.amin_ang(0.0, t1=1.0, t2=2.0, c=1.0)  # zero by construction, not missed


def test_a_step_at_a_piece_end_does_not_warn():
    # h(1) = 1 at the checked point 1.0, which ends the piece [0, 1] and starts the pause
    # [1, 2]: the point is on a piece end, where h may step, not a missed pulse.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        h, _ = envelopes.from_function(lambda t: 1.0 if t <= 1.0 else 0.0, 2.0, pieces=2)
    assert h == [1.0, 0.0]

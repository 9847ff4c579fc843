"""Calibration of runs to an accuracy of a filtered excitation (``simulate(scene, error=EPS)``
on a Kanai-Tajimi scene: crandall.model.FILTERED_LEVELS, docs/methods/adaptive.md).

Over many independent seeds, per case and target: how often the reported 95 % interval
(estimate +- 1.96 x ``Result.error``) holds the reference, and how often the estimate is within
the target itself (the target bounds the root-mean-square error, so this is a one-standard-
error claim: about 68 % or more, not 95 %), each with its Clopper-Pearson 95 % interval.

References, none from the code under test:

- ``frictionless``: mu = 0, so the body's velocity is minus the ground velocity, V = -G with
  G the integral of a_g, and its displacement -D with D the integral of G: their variances
  are the filter's augmented covariance, Van Loan's integral computed here with SciPy's
  expm; the mean distance int_0^t E|V| ds = sqrt(2 / pi) int_0^t sd V(s) ds (V Gaussian) by
  SciPy's quad.
- ``frictionless_peaks``: the same scene with the peaks observed. V = -G and U = -D, a
  Gaussian process, so the peak speed and the peak displacement up to t are the maxima over
  [0, t] of |G| and |D|: simulated here in NumPy from the filter's exact discretisation (SciPy's
  expm of Van Loan's block matrix) on a fine grid (PEAK_REF_STEP), whose every 2nd and 4th point
  give two coarser grids on the same paths; the mean and variance of each maximum are
  extrapolated to dt -> 0 from the three grids (the measured ratio of the paired differences),
  and the reference's standard error is its statistical one plus the whole extrapolation
  correction (as if it were all wrong), added in quadrature.
- ``euler_omega_tstar_4`` and ``_1``: the mean distance at the stop against the Euler anchors
  measured outside the project (32,000 paths at dt = 2.5e-4 s, zeta = 0.6, mu g = 1, h = 1,
  t0 = 10 s, static = kinetic friction): 0.776 +- 0.003 and 0.168 +- 0.002 of the white-noise
  value h^2 t0 / (2 mu g) = 5 at omega t* = 4 and 1 (tests/test_filtered.py). Their standard
  errors (0.015 and 0.01) are of the order of the runs' errors, so the interval is also
  counted with them added in quadrature ("coverage_with_reference_se").

Writes bench/out/filtered_error.{json,png} (bench/results/ with --publish).

    OMP_NUM_THREADS=1 .venv/bin/python bench/filtered_error.py [--seeds 200] [--threads 2] [--cases a,b]
        [--stem filtered_error] [--publish]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np
import scipy.integrate
import scipy.linalg
import scipy.stats

import crandall
from crandall import KanaiTajimi, Scene
from _publish import HERE, write

Z95 = 1.959963984540054
ZETA = 0.6
T0 = 10.0
WHITE = T0 / 2.0  # h^2 t0 / (2 mu g) with h = mu g = 1
TIMES = (1.0, 5.0)


def augmented_cov(omega: float, zeta: float, h: float, t: float) -> np.ndarray:
    """Cov of (x, x', G, D) at t from rest: Kanai-Tajimi's state, G = int a_g, D = int G,
    a_g = -omega^2 x - 2 zeta omega x', driven by -h dW (Van Loan's block exponential)."""
    w = omega
    a = np.array([[0.0, 1.0, 0.0, 0.0], [-w * w, -2 * zeta * w, 0.0, 0.0],
                  [-w * w, -2 * zeta * w, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    b = np.array([0.0, -1.0, 0.0, 0.0])
    n = 4
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -a
    m[:n, n:] = np.outer(b, b) * h * h
    m[n:, n:] = a.T
    e = scipy.linalg.expm(m * t)
    return e[n:, n:].T @ e[:n, n:]


def frictionless_references(omega: float = 2.0):
    out = {}
    for i, t in enumerate(TIMES):
        c = augmented_cov(omega, ZETA, 1.0, t)
        out[("velocity", "var", i)] = (float(c[2, 2]), 0.0)
        out[("displacement", "var", i)] = (float(c[3, 3]), 0.0)
        sd_integral = scipy.integrate.quad(
            lambda s: math.sqrt(max(augmented_cov(omega, ZETA, 1.0, s)[2, 2], 0.0)), 0.0, t,
            limit=200, epsabs=1e-12, epsrel=1e-10)[0]
        out[("distance", "mean", i)] = (math.sqrt(2.0 / math.pi) * sd_integral, 0.0)
    return out


#: The NumPy reference of the peaks: its fine step, paths (in chunks) and generator seed.
PEAK_REF_STEP = 0.01
PEAK_REF_PATHS = 2_000_000
PEAK_REF_CHUNK = 200_000
PEAK_REF_SEED = 20261127
#: What the peaks' reference measured (the grids' statistics, the ratios, the corrections),
#: written into the JSON when it was computed.
PEAK_REFERENCE_INFO = {}


def _transition(omega: float, zeta: float, h: float, step: float):
    """(Phi, a square root of Q) of (x, x', G, D) over ``step`` (Van Loan's block exponential,
    as augmented_cov)."""
    w = omega
    a = np.array([[0.0, 1.0, 0.0, 0.0], [-w * w, -2 * zeta * w, 0.0, 0.0],
                  [-w * w, -2 * zeta * w, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    b = np.array([0.0, -h, 0.0, 0.0])
    m = np.zeros((8, 8))
    m[:4, :4], m[:4, 4:], m[4:, 4:] = -a, np.outer(b, b), a.T
    e = scipy.linalg.expm(m * step)
    phi = e[4:, 4:].T
    q = phi @ e[:4, 4:]
    ev, v = np.linalg.eigh(0.5 * (q + q.T))
    return phi, v * np.sqrt(np.clip(ev, 0.0, None))


def frictionless_peak_references(omega: float = 2.0):
    """(name, stat, time index) -> (value, se): the mean and variance of max_[0,t] |G| (the
    peak speed) and max_[0,t] |D| (the peak displacement) at TIMES, extrapolated to dt -> 0 from
    the maxima over the NumPy paths' points on the grids PEAK_REF_STEP x 1, 2, 4."""
    if "references" in PEAK_REFERENCE_INFO:
        return PEAK_REFERENCE_INFO["references"]
    # Kept in bench/out between invocations with the same parameters (a few minutes' work).
    params = {"omega": omega, "zeta": ZETA, "times": list(TIMES), "step": PEAK_REF_STEP,
              "paths": PEAK_REF_PATHS, "chunk": PEAK_REF_CHUNK, "seed": PEAK_REF_SEED}
    cache = HERE / "out" / "filtered_error_peak_reference.json"
    if cache.exists():
        kept = json.loads(cache.read_text())
        if kept["params"] == params:
            PEAK_REFERENCE_INFO.update(kept["info"])
            PEAK_REFERENCE_INFO["references"] = {
                tuple(k.split("|")[:2]) + (int(k.split("|")[2]),): tuple(v)
                for k, v in kept["references"].items()}
            return PEAK_REFERENCE_INFO["references"]
    began = time.perf_counter()
    phi, root = _transition(omega, ZETA, 1.0, PEAK_REF_STEP)
    a_t, b_t = phi.T.copy(), root.T.copy()
    ends = [int(round(t / PEAK_REF_STEP)) for t in TIMES]
    assert all(abs(e * PEAK_REF_STEP - t) < 1e-12 for e, t in zip(ends, TIMES))
    subs = (1, 2, 4)
    # Per (quantity column, time, grid): sums of x - shift to the powers 1-4, and of the paired
    # differences (grid s minus grid 2s) of x and of (x - shift)^2 with their squares.
    shift = None
    sums = np.zeros((2, len(TIMES), len(subs), 4))
    dsums = np.zeros((2, len(TIMES), len(subs) - 1, 2, 2))
    n_total = 0
    seeds = np.random.SeedSequence(PEAK_REF_SEED).spawn(PEAK_REF_PATHS // PEAK_REF_CHUNK)
    for seed in seeds:
        n = PEAK_REF_CHUNK
        rng = np.random.Generator(np.random.SFC64(seed))
        y, y2, z = np.zeros((n, 4)), np.empty((n, 4)), np.empty((n, 4))
        peaks = np.zeros((len(subs), 2, n))  # per grid: max |G|, max |D|
        tmp = np.empty(n)
        for k in range(1, ends[-1] + 1):
            rng.standard_normal(out=z)
            np.matmul(y, a_t, out=y2)
            y2 += z @ b_t
            y, y2 = y2, y
            for g, s in enumerate(subs):
                if k % s == 0:
                    for col in (0, 1):
                        np.abs(y[:, 2 + col], out=tmp)
                        np.maximum(peaks[g, col], tmp, out=peaks[g, col])
            if k in ends:
                ti = ends.index(k)
                if shift is None:
                    shift = np.zeros((2, len(TIMES)))
                if n_total == 0:
                    shift[:, ti] = peaks[0].mean(axis=1)
                for col in (0, 1):
                    c = peaks[:, col] - shift[col, ti]
                    for p in range(4):
                        sums[col, ti, :, p] += (c ** (p + 1)).sum(axis=1)
                    for g in range(len(subs) - 1):
                        dm = c[g] - c[g + 1]
                        dv = c[g] ** 2 - c[g + 1] ** 2
                        dsums[col, ti, g, 0] += [dm.sum(), (dm * dm).sum()]
                        dsums[col, ti, g, 1] += [dv.sum(), (dv * dv).sum()]
        n_total += n
        print(f"peak reference: {n_total} paths, {time.perf_counter() - began:.0f} s",
              file=sys.stderr, flush=True)
    n = n_total
    out, info = {}, {"step": PEAK_REF_STEP, "paths": n, "seed": PEAK_REF_SEED,
                     "grids": [PEAK_REF_STEP * s for s in subs], "rows": {}}
    for col, name in enumerate(("peak_speed", "peak_displacement")):
        for ti in range(len(TIMES)):
            m = sums[col, ti] / n  # raw moments of x - shift, per grid
            mean = m[:, 0]
            var = (m[:, 1] - mean ** 2) * n / (n - 1)
            # Central fourth moment of the finest grid, for the variance's standard error.
            m1, m2, m3, m4 = m[0]
            c4 = m4 - 4 * m1 * m3 + 6 * m1 ** 2 * m2 - 3 * m1 ** 4
            se = {"mean": math.sqrt(var[0] / n),
                  "var": math.sqrt(max(c4 - var[0] ** 2, 0.0) / n)}
            for stat, values, idx in (("mean", mean + shift[col, ti], 0), ("var", var, 1)):
                # Paired differences finer minus coarser grid: d1 (dt, 2 dt), d2 (2 dt, 4 dt).
                d = []
                for g in range(len(subs) - 1):
                    s1, s2 = dsums[col, ti, g, idx]
                    dm = s1 / n
                    if stat == "var":
                        # Var_f - Var_2f = E[c_f^2 - c_2f^2] - (E c_f)^2 + (E c_2f)^2.
                        dm = (dm - mean[g] ** 2 + mean[g + 1] ** 2) * n / (n - 1)
                    d.append((dm, math.sqrt(max(s2 / n - (s1 / n) ** 2, 0.0) / n)))
                (d1, se1), (d2, se2) = d
                ratio = d2 / d1 if d1 != 0 else math.inf
                # The rest beyond the finest grid, falling by the measured ratio per halving
                # where both differences are resolved and it exceeds 2, else first order's
                # (ratio 2: the rest is d1 itself).
                r = ratio if (abs(d1) > 2 * se1 and abs(d2) > 2 * se2 and ratio > 2) else 2.0
                correction = d1 / (r - 1.0)
                value = float(values[0] + correction)
                ref_se = math.hypot(se[stat], correction)
                out[(name, stat, ti)] = (value, ref_se)
                info["rows"][f"{name}_{stat}@{TIMES[ti]:g}"] = {
                    "grids": [float(v) for v in values], "d1": d1, "d1_se": se1, "d2": d2,
                    "d2_se": se2, "ratio": ratio, "ratio_used": r, "correction": correction,
                    "statistical_se": se[stat], "value": value, "se": ref_se}
    info["wall_time"] = time.perf_counter() - began
    PEAK_REFERENCE_INFO.update(info)
    PEAK_REFERENCE_INFO["references"] = out
    cache.parent.mkdir(exist_ok=True)
    cache.write_text(json.dumps({"params": params, "info": info, "references": {
        f"{k[0]}|{k[1]}|{k[2]}": list(v) for k, v in out.items()}}, indent=1))
    return out


def cases():
    """name -> (scene, statistics, target kind, target, references: key -> (value, its se))."""
    frictionless = Scene(mu=0.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=ZETA, h=1.0),
                         t0=T0, times=list(TIMES),
                         observe=["velocity", "displacement", "distance"])
    refs = frictionless_references()
    out = {}
    for rel in (0.02, 0.05):
        out[f"frictionless_rel_{rel:g}"] = (
            frictionless, ["velocity:var", "displacement:var", "distance:mean"], "rel_error",
            rel, refs)
    peaks = Scene(mu=0.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=ZETA, h=1.0), t0=T0,
                  times=list(TIMES), observe=["velocity", "displacement", "peaks"])
    for rel in (0.02, 0.01):
        out[f"frictionless_peaks_rel_{rel:g}"] = (
            peaks, ["peak_speed:mean", "peak_speed:var", "peak_displacement:mean",
                    "peak_displacement:var"], "rel_error", rel, frictionless_peak_references)
    # Nearly without friction (mu g = 1e-4): the default step is then the filter's 1 / omega
    # (0.5 s; level 0 at 2 s, graded), so coarse that the peaks' grid bias is a sizeable part
    # of the error and the bias estimate is put to the test. The friction's deceleration is at
    # most mu g, so |V + G| <= mu g t and |U + D| <= mu g t^2 / 2: the maxima differ from the
    # frictionless ones by at most that (and a variance by 2 sd delta + delta^2), counted as
    # the reference's error in quadrature with its standard error.
    mu_g = 1e-4
    tiny = Scene(mu=mu_g, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=ZETA, h=1.0), t0=T0,
                 times=list(TIMES), observe=["velocity", "displacement", "peaks"])

    def tiny_references():
        out = {}
        for (name, stat, i), (value, se) in frictionless_peak_references().items():
            t = TIMES[i]
            delta = mu_g * t if name == "peak_speed" else mu_g * t * t / 2.0
            if stat == "var":
                delta = 2.0 * math.sqrt(value) * delta + delta * delta
            out[(name, stat, i)] = (value, math.hypot(se, delta))
        return out

    for rel in (0.02, 0.01):
        out[f"tiny_friction_peaks_rel_{rel:g}"] = (
            tiny, ["peak_speed:mean", "peak_speed:var", "peak_displacement:mean",
                   "peak_displacement:var"], "rel_error", rel, tiny_references)
    for tag, omega, anchor, se, targets in (("euler_omega_tstar_4", 2.0, 0.776, 0.003,
                                             (0.03, 0.06)),
                                            ("euler_omega_tstar_1", 0.5, 0.168, 0.002,
                                             (0.02, 0.04))):
        sc = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=omega, zeta=ZETA, h=1.0), t0=T0,
                   times=[T0], observe=["distance", "stop"])
        for eps in targets:
            out[f"{tag}_error_{eps:g}"] = (
                sc, ["distance_at_stop:mean"], "error", eps,
                {("distance_at_stop", "mean", None): (anchor * WHITE, se * WHITE)})
    return out


def clopper_pearson(k: int, n: int):
    lo = 0.0 if k == 0 else float(scipy.stats.beta.ppf(0.025, k, n - k + 1))
    hi = 1.0 if k == n else float(scipy.stats.beta.ppf(0.975, k + 1, n - k))
    return [lo, hi]


def key_name(key) -> str:
    name, stat, i = key
    return f"{name}_{stat}" + ("" if i is None else f"@{TIMES[i]:g}")


def run_case(name, case, seeds: int, first_seed: int, threads: int):
    scene, statistics, kind, target, refs = case
    if callable(refs):  # computed when a case needs it (the peaks' NumPy reference)
        refs = refs()
    rows = {key_name(k): {"reference": v[0], "reference_se": v[1], "inside": 0,
                          "inside_with_reference_se": 0, "within_target": 0, "z": [],
                          "error": [], "bias": []} for k, v in refs.items()}
    costs = []
    for s in range(first_seed, first_seed + seeds):
        r = crandall.simulate(scene, seed=s, threads=threads, statistics=statistics,
                              **{kind: target})
        assert r.model == "filtered_levels"
        costs.append(r.cost)
        for key, (ref, ref_se) in refs.items():
            q, stat, i = key
            value = r.mean(q) if stat == "mean" else r.var(q)
            err, bias = r.error(q, stat), r.bias(q, stat)
            if i is not None:
                value, err, bias = value[i], err[i], bias[i]
            row = rows[key_name(key)]
            tol = target if kind == "error" else target * abs(ref)
            row["inside"] += int(abs(value - ref) <= Z95 * err)
            row["inside_with_reference_se"] += int(abs(value - ref) <= Z95 * math.hypot(err, ref_se))
            row["within_target"] += int(abs(value - ref) <= tol)
            row["z"].append(float((value - ref) / err))
            row["error"].append(float(err))
            row["bias"].append(float(bias))
        print(f"{name} seed {s}: {time.strftime('%H:%M:%S')}", file=sys.stderr, flush=True)
    for row in rows.values():
        row["coverage"] = row["inside"] / seeds
        row["coverage_interval"] = clopper_pearson(row["inside"], seeds)
        row["coverage_with_reference_se"] = row["inside_with_reference_se"] / seeds
        row["coverage_with_reference_se_interval"] = clopper_pearson(
            row["inside_with_reference_se"], seeds)
        row["within_target_fraction"] = row["within_target"] / seeds
        row["within_target_interval"] = clopper_pearson(row["within_target"], seeds)
        row["rms_z"] = float(np.sqrt(np.mean(np.square(row["z"]))))
        row["mean_z"] = float(np.mean(row["z"]))
        row["max_error"] = max(row["error"])
        row["mean_bias_over_error"] = float(np.mean(np.array(row["bias"]) / np.array(row["error"])))
    return {"scene": scene.to_dict(), "statistics": statistics, kind: target, "seeds": seeds,
            "first_seed": first_seed, "rows": rows,
            "wall_time_mean": float(np.mean([c["wall_time"] for c in costs])),
            "paths_mean": [float(np.mean([c["paths"][k] if k < len(c["paths"]) else 0
                                          for c in costs]))
                           for k in range(max(len(c["paths"]) for c in costs))]}


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels, cov, lo, hi = [], [], [], []
    for cname, c in data["cases"].items():
        for rname, row in c["rows"].items():
            labels.append(f"{cname}: {rname}")
            cov.append(row["coverage_with_reference_se"])
            lo.append(row["coverage_with_reference_se_interval"][0])
            hi.append(row["coverage_with_reference_se_interval"][1])
    y = np.arange(len(labels))
    fig, ax = plt.subplots(figsize=(8, 0.4 * len(labels) + 1.5))
    ax.errorbar(cov, y, xerr=[np.array(cov) - lo, np.array(hi) - cov], fmt="o")
    ax.axvline(0.95, color="g", label="nominal 95 %")
    ax.set_yticks(y, labels)
    ax.set_xlim(0.8, 1.0)
    ax.set_xlabel(f"coverage of the 95 % interval ({data['seeds']} seeds per case; "
                  "Clopper-Pearson 95 %)")
    ax.legend(loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--cases", default=None, help="comma-separated subset of the cases")
    ap.add_argument("--stem", default="filtered_error", help="the output files' name")
    ap.add_argument("--publish", action="store_true")
    a = ap.parse_args()
    t = time.perf_counter()
    chosen = cases()
    if a.cases:
        chosen = {k: chosen[k] for k in a.cases.split(",")}
    data = {"seeds": a.seeds, "cases": {}}
    for name, case in chosen.items():
        data["cases"][name] = run_case(name, case, a.seeds, a.first_seed, a.threads)
    if PEAK_REFERENCE_INFO:
        data["peak_reference"] = {k: v for k, v in PEAK_REFERENCE_INFO.items()
                                  if k != "references"}
    data["wall_time_total"] = time.perf_counter() - t
    data["command"] = " ".join(["bench/filtered_error.py"] + sys.argv[1:])
    data["crandall"] = crandall.__version__
    for cname, c in data["cases"].items():
        for rname, row in c["rows"].items():
            print(f"{cname:22s} {rname:24s} coverage {row['coverage']:.3f} "
                  f"(with ref se {row['coverage_with_reference_se']:.3f}, "
                  f"CP {row['coverage_with_reference_se_interval'][0]:.3f}-"
                  f"{row['coverage_with_reference_se_interval'][1]:.3f})  within target "
                  f"{row['within_target_fraction']:.3f}  rms z {row['rms_z']:.2f}  "
                  f"mean z {row['mean_z']:+.2f}")
    for c in data["cases"].values():
        for row in c["rows"].values():
            del row["z"], row["error"], row["bias"]
    write(a.stem, data, plot, publish=a.publish)


if __name__ == "__main__":
    main()

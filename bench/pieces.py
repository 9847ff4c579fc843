"""Piecewise intensity: what pieces cost, and the time to an answer against a NumPy
Euler-Maruyama peer on an earthquake envelope. One thread, one run (speeds are compared as
ratios measured in the same run: the machine is shared).

1. The cost of pieces. An SI scene (mu = 0.35, g = 9.81, shaken for 10 s) whose intensity is
   an Amin-Ang variance envelope (h^2 = 0.36 (t / 2)^2 up to 2 s, 0.36 until 6 s, then
   0.36 exp(-0.5 (t - 6))) cut into 1, 10, 100 and 1000 equal pieces by
   ``crandall.envelopes.from_function`` (each piece the root mean square of the envelope on
   it: int h^2 dt, hence the mean distance at the stop, is the same for every cut; 1 piece is
   the scalar scene). Timed, as wall time per path (the median of --repeat runs, the runs of
   the four cuts interleaved):
   (a) observing velocity and stop (one output time, at 10 s): no internal steps, one exact
       step per segment, so the cost should grow with the number of pieces;
   (b) observing distance and stop with dt = 1e-3 (10 000 steps per path), with the exact
       method and the default one: the pieces should cost little on top of the steps.
   Each is reported with its ratio to 1 piece.

2. Time to an answer. The shipped scene cabinet_amin_ang (read with
   ``crandall.Scene.from_toml``; observing distance and stop only, one output time at the
   last piece end), the statistic the variance of the distance at the stop. The target is a
   RELATIVE error (root-mean-square, bias and statistical error together) of 1e-3 of that
   variance (--quick: 1e-2; the full run also does 1e-2): the variance is about
   1.15e-3 m^2, so an absolute 1e-3 m^2 would be 87 % of the answer itself (crandall's
   pilot alone meets it; that run is recorded too, without a peer).
   - crandall: ``simulate(scene, rel_error=R, statistics=[("distance_at_stop", "var"),
     ("distance_at_stop", "mean")], threads=1)``, run in full (it takes the variance as the
     mean of int h^2 V^2 dt / (mu g)^2, Ito's isometry); its answer and reported error are
     the reference the peer's bias is measured against.
   - The peer, bench/peers/numpy_em_pieces.py (NumPy vectorised Euler-Maruyama, steps of at
     most dt ending on every piece end, closed-form coast), EPS = R times crandall's
     variance in m^2. Its bias of the variance is measured at several dt against crandall's
     answer; a power law c dt^p is fitted through the resolved points (beyond 3 combined
     standard errors), once through all of them and once through the finest three, and the
     cheaper of the two is used (the benefit of the doubt); the step and paths minimise
     paths x steps under bias^2 + V / N <= EPS^2, V the per-path variance of the variance
     estimator (its fourth central moment minus the variance squared, measured at the finest
     dt, relative to the variance). The peer is timed at the chosen dt on --peer-paths paths
     and scaled linearly to the paths it needs (run in full if it needs fewer); every point
     records whether it was run or scaled.
   - The same peer with the estimator crandall uses (``quadratic=True``: the mean of
     sum h^2 V_k^2 dt / (mu g)^2 over the Euler steps, V its per-path variance), measured and
     chosen the same way: how much of crandall's lead is the identity, and how much the exact
     skeleton and the levels.

3. Checks that can fail (the script exits with status 1 and does not publish): the mean
   distance at the stop against the energy law E[mu g S(t_s)] = v0^2 / 2 + (1/2) int h^2 dt
   for every cut of part 1 (b) and for a fixed-step run of the cabinet scene, within 4
   reported errors (sqrt(stderr^2 + bias^2)); the fixed-step variance against the accuracy
   run's within 4 combined errors; crandall's reported error within its target; the peer's
   mean against the value its scheme has exactly (the law plus a^2 sum dt_k^2 / (2 a),
   bench/peers/numpy_em_pieces.py), within 4 standard errors, at every dt; the peer's timed
   run against the reference plus its predicted bias.

Writes bench/out/pieces.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/pieces.py [--quick] [--publish] [--repeat 5]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics as pystats
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402
from peers import numpy_em_pieces as peer  # noqa: E402

import crandall  # noqa: E402
from crandall import envelopes  # noqa: E402
from crandall.methods import DEFAULT_METHOD  # noqa: E402

THREADS = 1
MU, G = 0.35, 9.81
A = MU * G
# Part 1: the envelope and its cuts.
HORIZON = 10.0
H_STRONG, T1, T2, DECAY = 0.6, 2.0, 6.0, 0.5
PIECES = (1, 10, 100, 1000)
DT_FIXED = 1e-3
# Part 2.
SCENE_FILE = "cabinet_amin_ang"
STAT = ("distance_at_stop", "var")
PEER_BATCH = 16384
SEED = 7


def envelope(pieces: int):
    """Amin & Ang's envelope in exactly ``pieces`` equal pieces (envelopes.amin_ang would add
    its corners as piece ends): its function, cut by from_function."""
    shape = envelopes.amin_ang(H_STRONG, T1, T2, DECAY, end=HORIZON, pieces=1).function
    return envelopes.from_function(shape, HORIZON, pieces)


def energy_law(h, ends, v0=0.0) -> float:
    """E S(t_s) from E[mu g S(t_s)] = v0^2 / 2 + (1/2) int h^2 dt."""
    starts = [0.0] + list(ends[:-1])
    return (v0 ** 2 + sum(x * x * (e - s) for x, s, e in zip(h, starts, ends))) / (2 * A)


class Checks:
    def __init__(self):
        self.rows = []

    def add(self, name, value, expected, tolerance, note=""):
        ok = bool(abs(value - expected) <= tolerance)
        self.rows.append({"name": name, "value": value, "expected": expected,
                          "tolerance": tolerance, "passed": ok, "note": note})
        print(f"  check {'ok  ' if ok else 'FAIL'} {name}: {value:.6g} vs {expected:.6g} "
              f"(tolerance {tolerance:.3g}) {note}", flush=True)

    @property
    def passed(self):
        return all(r["passed"] for r in self.rows)


# ------------------------------------------------------------------ part 1: the cost of pieces

def cost_of_pieces(repeat: int, quick: bool, checks: Checks):
    scale = 0.25 if quick else 1.0
    # Paths per timed run: about 0.2-0.5 s each on this kind of machine.
    paths_a = {1: 4_000_000, 10: 2_000_000, 100: 400_000, 1000: 50_000}
    paths_b = 10_000
    cuts = {}
    for n in PIECES:
        h, ends = envelope(n)
        cuts[n] = {"h": h, "ends": ends, "law": energy_law(h, ends)}
    variants = {"velocity_stop": (["velocity", "stop"], None, None),
                "distance_stop_exact": (["distance", "stop"], DT_FIXED, "exact"),
                "distance_stop_default": (["distance", "stop"], DT_FIXED, None)}
    walls = {(v, n): [] for v in variants for n in PIECES}
    last = {}
    for rep in range(repeat):
        for v, (observe, dt, method) in variants.items():
            for n in PIECES:
                c = cuts[n]
                scene = crandall.Scene(mu=MU, g=G, h=c["h"], t0=c["ends"], times=[HORIZON],
                                       observe=observe)
                paths = int((paths_a[n] if dt is None else paths_b) * scale)
                kw = {} if dt is None else {"dt": dt}
                if method is not None:
                    kw["method"] = method
                t = time.perf_counter()
                r = crandall.simulate(scene, paths=paths, seed=rep + 1, threads=THREADS, **kw)
                walls[(v, n)].append((time.perf_counter() - t) / paths)
                last[(v, n)] = (r, paths)
        print(f"  pieces: repeat {rep + 1}/{repeat} done", flush=True)
    out = {"horizon_s": HORIZON, "mu": MU, "g": G,
           "envelope": {"kind": "Amin-Ang variance envelope, crandall.envelopes.from_function",
                        "h": H_STRONG, "t1": T1, "t2": T2, "c": DECAY},
           "dt": DT_FIXED, "repeat": repeat, "noise_energy": {}, "runs": {}}
    for v, (observe, dt, method) in variants.items():
        rows = []
        for n in PIECES:
            r, paths = last[(v, n)]
            med = pystats.median(walls[(v, n)])
            rows.append({"pieces": n, "paths": paths, "steps_per_path": r.steps_per_path,
                         "seconds_per_path": med, "seconds_per_path_all": walls[(v, n)]})
        for row in rows:
            row["ratio_to_1_piece"] = row["seconds_per_path"] / rows[0]["seconds_per_path"]
            print(f"  {v:22s} {row['pieces']:5d} pieces: {row['seconds_per_path'] * 1e9:10.1f} "
                  f"ns/path ({row['steps_per_path']} steps), x{row['ratio_to_1_piece']:.2f}",
                  flush=True)
        out["runs"][v] = {"observe": observe, "dt": dt,
                          "method": method or DEFAULT_METHOD,
                          "rows": rows}
    for n in PIECES:
        out["noise_energy"][str(n)] = 2 * A * cuts[n]["law"]
        # The energy law, on the last run of each cut with the default method.
        r, _ = last[("distance_stop_default", n)]
        err = math.hypot(float(r.stderr("distance_at_stop")), float(r.bias("distance_at_stop")))
        checks.add(f"pieces={n}: mean distance at the stop (m) vs energy law",
                   float(r.mean("distance_at_stop")), cuts[n]["law"], 4 * err,
                   "4 reported errors (default method, dt = 1e-3)")
    return out


# ------------------------------------------------------------------ part 2: time to an answer

def cabinet_scene():
    """The shipped scene's pieces (what the peer simulates: the file gives them as an Amin-Ang
    envelope, whose piece error is not what is timed here), observing distance and stop
    only, one output time at the last end."""
    full = crandall.Scene.from_toml(SCENE_FILE)
    d = full.to_dict()
    d.pop("distributions", None)
    d.pop("bins", None)
    if "envelope" in d:
        env = d.pop("envelope")
        d["h"], d["t0"] = [float(x) for x in full.envelope.h], [float(x) for x in full.envelope.t0]
        assert env["pieces"] == 16
    d["observe"] = ["distance", "stop"]
    d["times"] = [full.t0]
    return crandall.Scene.from_dict(d), d


def crandall_to_error(scene, rel):
    t = time.perf_counter()
    r = crandall.simulate(scene, rel_error=rel, seed=SEED, threads=THREADS,
                          statistics=[STAT, ("distance_at_stop", "mean")])
    wall = time.perf_counter() - t
    return r, {"seconds": wall, "run": True, "rel_error": rel,
               "var": float(r.var("distance_at_stop")),
               "reported_error": float(r.error(*STAT)), "bias": float(r.bias(*STAT)),
               "stderr": float(r.var_stderr("distance_at_stop")),
               "mean": float(r.mean("distance_at_stop")),
               "mean_error": float(r.error("distance_at_stop", "mean")),
               "path_steps": r.cost["path_steps"], "paths": r.cost["paths"],
               "rounds": r.cost["rounds"]}


def peer_run(paths, dt, h, ends, seed, estimator="direct"):
    """The peer on ``paths`` paths: the mean distance at the stop, and the variance as the
    plain sample variance ("direct") or as the mean quadratic variation over (mu g)^2
    ("isometry", computed only then); V is the per-path variance of its summand."""
    iso = estimator == "isometry"
    t = time.perf_counter()
    o = peer.simulate(paths, dt, h, ends, MU, G, seed=seed, batch=PEER_BATCH, quadratic=iso)
    wall = time.perf_counter() - t
    x = o["distance_at_stop"]
    m = float(x.mean())
    c = x - m
    v = float(c @ c / (paths - 1))
    m4 = float(np.mean(c ** 4))
    out = {"dt": dt, "paths": paths, "steps_per_path": peer.steps(ends, dt), "seconds": wall,
           "estimator": estimator,
           "mean": m, "mean_stderr": float(x.std(ddof=1) / math.sqrt(paths)),
           "var": v, "var_stderr": math.sqrt(max(m4 - v * v, 0.0) / paths),
           "kappa": (m4 - v * v) / (v * v), "V": max(m4 - v * v, 0.0)}
    if iso:
        y = o["quadratic_variation"] / (A * A)
        out["sample_var"] = v
        out["var"] = float(y.mean())
        out["V"] = float(y.var(ddof=1))
        out["var_stderr"] = math.sqrt(out["V"] / paths)
    return out


def fit(points):
    x = np.log([p[0] for p in points])
    y = np.log([p[1] for p in points])
    p, logc = np.polyfit(x, y, 1)
    return {"c": float(math.exp(logc)), "p": float(p),
            "through_dt": [float(q[0]) for q in points]}


def peer_choice(eps, law, V, rate, ends, dt_cap):
    """The step dt (bias c dt^p < eps, dt <= dt_cap) and paths minimising paths x steps."""
    c, p = law["c"], law["p"]
    dt_lim = min((eps / c) ** (1.0 / p), dt_cap)
    best = None
    for f in np.linspace(0.05, 0.995, 190):
        dt = float(f * dt_lim)
        bias = c * dt ** p
        if bias >= eps:
            continue
        paths = max(2, math.ceil(V / (eps ** 2 - bias ** 2)))
        seconds = paths * peer.steps(ends, dt) * rate
        if best is None or seconds < best["predicted_seconds"]:
            best = {"dt": dt, "paths": paths, "bias": bias, "predicted_seconds": seconds,
                    "steps_per_path": peer.steps(ends, dt)}
    return best


def time_to_answer(quick: bool, peer_paths: int, checks: Checks):
    scene, d = cabinet_scene()
    h, ends = d["h"], d["t0"]
    law = energy_law(h, ends)
    out = {"scene_file": "cabinet_amin_ang", "observe": d["observe"],
           "times": d["times"], "statistic": "variance of the distance at the stop (m^2)",
           "target": "relative: EPS = R x the variance (root-mean-square error, bias and "
                     "statistical error together)",
           "pieces": len(h), "noise_energy": 2 * A * law, "energy_law_mean": law}
    # The literal absolute 1e-3 m^2: crandall's pilot meets it.
    t = time.perf_counter()
    r_abs = crandall.simulate(scene, error=1e-3, seed=SEED, threads=THREADS, statistics=[STAT])
    out["absolute_1e-3_m2"] = {"seconds": time.perf_counter() - t,
                               "var": float(r_abs.var("distance_at_stop")),
                               "reported_error": float(r_abs.error(*STAT)),
                               "paths": r_abs.cost["paths"],
                               "note": "an absolute 1e-3 m^2 is most of the variance itself; "
                                       "no peer is timed for it"}
    print(f"  crandall error=1e-3 (absolute, m^2): {out['absolute_1e-3_m2']['seconds']:.2f} s, "
          f"var {out['absolute_1e-3_m2']['var']:.4g}", flush=True)

    rels = (1e-2,) if quick else (1e-2, 1e-3)
    rows = []
    ref = None
    for rel in rels:
        r, c = crandall_to_error(scene, rel)
        print(f"  crandall rel_error={rel:g}: {c['seconds']:.2f} s, var {c['var']:.6g} +- "
              f"{c['reported_error']:.2g} (paths per level {c['paths']})", flush=True)
        checks.add(f"crandall rel_error={rel:g}: reported error within the target",
                   c["reported_error"], 0.0, rel * abs(c["var"]))
        checks.add(f"crandall rel_error={rel:g}: mean distance at the stop (Ito constant) vs "
                   f"energy law", c["mean"], law, 1e-9 * law,
                   "the accuracy run takes it from the exact velocity: it reads the pieces")
        rows.append({"rel_error": rel, "crandall": c})
        ref = c  # the most accurate run is the reference
    ref_var, ref_err = ref["var"], ref["reported_error"]

    # The peer's bias of the variance against crandall's answer: with the plain sample
    # variance (the way a user writes it), and with the same Ito isometry crandall uses.
    out["rows"] = rows
    out["reference"] = {"var": ref_var, "reported_error": ref_err}
    for estimator, key in (("direct", "peer"), ("isometry", "peer_isometry")):
        info = peer_answers(estimator, key, quick, rows, rels, ref_var, ref_err, h, ends, law,
                            peer_paths, checks)
        out["peer_bias" if estimator == "direct" else "peer_isometry_bias"] = info
    return out


def peer_answers(estimator, key, quick, rows, rels, ref_var, ref_err, h, ends, law,
                 peer_paths, checks):
    """The peer with one estimator of Var S(t_s): its bias measured on a ladder of steps
    against crandall's answer, a power law fitted, and per row the step and paths that reach
    EPS soonest, timed (scaled in paths when it needs more than peer_paths)."""
    ladder = ([(0.05, 20_000), (0.025, 40_000), (0.0125, 40_000)] if quick else
              [(0.05, 50_000), (0.025, 100_000), (0.0125, 200_000), (0.00625, 200_000),
               (0.003125, 200_000)])
    iso = estimator == "isometry"
    points = []
    for i, (dt, n) in enumerate(ladder):
        p = peer_run(n, dt, h, ends, seed=(200 if iso else 100) + i, estimator=estimator)
        p["bias"] = p["var"] - ref_var
        p["bias_error"] = math.hypot(p["var_stderr"], ref_err)
        p["resolved"] = abs(p["bias"]) > 3 * p["bias_error"]
        exact_mean = peer.mean_distance_at_stop(dt, h, ends, MU, G)
        p["scheme_mean"] = exact_mean
        p["mean_bias_vs_law"] = exact_mean - law
        points.append(p)
        print(f"  peer ({estimator}) dt={dt:g}: {p['seconds']:.1f} s ({n} paths x "
              f"{p['steps_per_path']} steps), var {p['var']:.4g} +- {p['var_stderr']:.2g}, bias "
              f"{p['bias']:+.3g} ({p['bias'] / ref_var:+.2%}), mean {p['mean']:.5g} "
              f"(law {law:.5g})", flush=True)
        checks.add(f"peer ({estimator}) dt={dt:g}: mean distance at the stop vs its scheme's "
                   f"exact mean", p["mean"], exact_mean, 4 * p["mean_stderr"],
                   f"the scheme's mean is the law + {exact_mean - law:.3g} m")
    resolved = [(q["dt"], abs(q["bias"])) for q in points if q["resolved"]]
    if len(resolved) < 2:
        checks.add(f"peer ({estimator}): resolved bias points", len(resolved), 2, 0,
                   "need at least 2")
        return {"points": points}
    resolved.sort()
    laws = {"all": fit(resolved), "finest_three": fit(resolved[:3])}
    finest = min(points, key=lambda q: q["dt"])
    kappa = finest["kappa"]
    rate = finest["seconds"] / (finest["paths"] * finest["steps_per_path"])
    dt_cap = max(q["dt"] for q in points)
    print(f"  peer ({estimator}) bias laws: "
          + ", ".join(f"{k}: {v['c']:.3g} dt^{v['p']:.3f}" for k, v in laws.items())
          + f"; kappa {kappa:.3g}; {rate * 1e9:.1f} ns per path-step", flush=True)
    for row in rows:
        eps = row["rel_error"] * ref_var
        # The per-path variance of the estimator's summand: the squared centred distance's
        # (kappa Var^2), or the quadratic variation's own, measured at the finest step.
        V = finest["V"] if iso else kappa * ref_var ** 2
        options = {k: peer_choice(eps, law_, V, rate, ends, dt_cap) for k, law_ in laws.items()}
        used = min(options, key=lambda k: options[k]["predicted_seconds"])
        choice = dict(options[used], law=used, eps=eps, V=V)
        timed = min(peer_paths, choice["paths"])
        run = peer_run(timed, choice["dt"], h, ends, seed=(2000 if iso else 1000)
                       + rels.index(row["rel_error"]), estimator=estimator)
        seconds = run["seconds"] * choice["paths"] / timed
        choice.update({"timed_paths": timed, "timed_seconds": run["seconds"],
                       "seconds": seconds, "run": timed == choice["paths"],
                       "scaled_from": None if timed == choice["paths"] else timed,
                       "timed_var": run["var"], "timed_var_stderr": run["var_stderr"],
                       "options": options})
        row[key] = choice
        row["eps_m2"] = eps
        row[f"ratio_{key}_to_crandall"] = seconds / row["crandall"]["seconds"]
        print(f"  rel {row['rel_error']:g} (EPS {eps:.3g} m^2): peer ({estimator}) dt "
              f"{choice['dt']:.3g} s, {choice['paths']} paths, {choice['steps_per_path']} steps "
              f"({used} law), {seconds:.1f} s "
              f"{'run' if choice['run'] else f'scaled from {timed} paths'}; crandall "
              f"{row['crandall']['seconds']:.1f} s: ratio "
              f"{row[f'ratio_{key}_to_crandall']:.1f}", flush=True)
        checks.add(f"peer ({estimator}) rel {row['rel_error']:g}: timed run's variance vs "
                   f"reference + predicted bias", run["var"], ref_var + choice["bias"],
                   4 * math.hypot(run["var_stderr"], ref_err))
    return {"points": points, "laws": laws, "kappa": kappa, "V_finest": finest["V"],
            "seconds_per_path_step": rate, "batch": PEER_BATCH}


def fixed_step_check(quick: bool, checks: Checks, ref):
    """The cabinet scene on a fixed grid: a sample mean with its own reported error."""
    scene, d = cabinet_scene()
    law = energy_law(d["h"], d["t0"])
    paths = 20_000 if quick else 100_000
    t = time.perf_counter()
    r = crandall.simulate(scene, paths=paths, seed=SEED, dt=0.01, threads=THREADS)
    wall = time.perf_counter() - t
    m, se, b = (float(r.mean("distance_at_stop")), float(r.stderr("distance_at_stop")),
                float(r.bias("distance_at_stop")))
    v, vse, vb = (float(r.var("distance_at_stop")), float(r.var_stderr("distance_at_stop")),
                  float(r.bias("distance_at_stop", "var")))
    checks.add("cabinet, fixed step dt = 0.01: mean distance at the stop (m) vs energy law",
               m, law, 4 * math.hypot(se, b), f"{paths} paths, 4 reported errors")
    if ref is not None:
        checks.add("cabinet, fixed step dt = 0.01: variance vs the accuracy run's", v,
                   ref["var"], 4 * math.sqrt(vse ** 2 + vb ** 2 + ref["reported_error"] ** 2),
                   "4 combined errors")
    return {"paths": paths, "dt": 0.01, "seconds": wall, "mean": m, "mean_stderr": se,
            "mean_bias": b, "var": v, "var_stderr": vse, "var_bias": vb, "law": law}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="fewer paths and repeats, relative error 1e-2 only (a smoke run)")
    ap.add_argument("--publish", action="store_true")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--peer-paths", type=int, default=PEER_BATCH,
                    help="paths of the peer's timed run at its chosen step")
    a = ap.parse_args()
    repeat = min(a.repeat, 3) if a.quick else a.repeat
    started = time.perf_counter()
    out = {"script": "bench/pieces.py",
           "command": " ".join(["bench/pieces.py"] + sys.argv[1:]),
           "crandall": crandall.__version__, "build": crandall._core.build_info(),
           "numpy": np.__version__,
           "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                       "processor": platform.processor() or platform.machine(),
                       "load_before": os.getloadavg()[0]},
           "threads": THREADS}
    checks = Checks()
    print("1. the cost of pieces", flush=True)
    out["cost_of_pieces"] = cost_of_pieces(repeat, a.quick, checks)
    print("2. time to an answer", flush=True)
    out["time_to_answer"] = tta = time_to_answer(a.quick, a.peer_paths, checks)
    print("3. fixed-step check", flush=True)
    tta["fixed_step_check"] = fixed_step_check(a.quick, checks, tta.get("reference"))
    out["checks"] = checks.rows
    out["checks_passed"] = checks.passed
    out["machine"]["load_after"] = os.getloadavg()[0]
    out["wall_seconds"] = time.perf_counter() - started
    write("pieces", out, plot, publish=a.publish and checks.passed)
    print(f"{len(checks.rows)} checks, {'all passed' if checks.passed else 'SOME FAILED'}; "
          f"{out['wall_seconds']:.0f} s", flush=True)
    if not checks.passed:
        print("not published: a check failed", flush=True)
        sys.exit(1)


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8), constrained_layout=True)
    ax = axes[0]
    cp = data["cost_of_pieces"]
    labels = {"velocity_stop": "velocity + stop (no internal steps)",
              "distance_stop_exact": "distance + stop, dt = 1e-3, exact",
              "distance_stop_default": "distance + stop, dt = 1e-3, default method"}
    for key, run in cp["runs"].items():
        xs = [r["pieces"] for r in run["rows"]]
        ys = [r["seconds_per_path"] * 1e6 for r in run["rows"]]
        ax.loglog(xs, ys, "o-", label=labels[key])
        # Every ratio of the velocity-only line; the last one of the others (all near 1).
        for x, y, r in list(zip(xs, ys, run["rows"]))[0 if key == "velocity_stop" else -1:]:
            ax.annotate(f"x{r['ratio_to_1_piece']:.3g}", (x, y), textcoords="offset points",
                        xytext=(-10, 6 if key != "distance_stop_exact" else -12), fontsize=7)
    ax.set_xlabel("pieces (same envelope, 10 s)")
    ax.set_ylabel("wall time per path (us), 1 thread, median")
    ax.set_title("the cost of pieces", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)

    tta = data["time_to_answer"]
    ax = axes[1]
    grid = None
    for key, label, colour in (("peer_bias", "sample variance", "tab:orange"),
                               ("peer_isometry_bias", "Ito isometry", "tab:green")):
        pb = tta.get(key, {})
        pts = pb.get("points", [])
        if not pts:
            continue
        ax.errorbar([p["dt"] for p in pts], [abs(p["bias"]) for p in pts],
                    yerr=[p["bias_error"] for p in pts], fmt="o", capsize=2, color=colour,
                    label=f"peer, {label}: |Var S(t_s) - crandall's|")
        grid = np.geomspace(1e-4, max(p["dt"] for p in pts), 50)
        for name, law in pb.get("laws", {}).items():
            ax.loglog(grid, law["c"] * grid ** law["p"], "--", lw=1, color=colour,
                      alpha=1.0 if name == "all" else 0.5,
                      label=f"fit ({name}): {law['c']:.3g} dt^{law['p']:.2f}")
    if grid is not None:
        for row in tta["rows"]:
            ax.axhline(row["eps_m2"], color="grey", lw=0.8, ls=":")
            ax.annotate(f"EPS (R = {row['rel_error']:g})", (grid[0], row["eps_m2"]),
                        fontsize=7, xytext=(0, 2), textcoords="offset points")
            for key, colour in (("peer", "tab:orange"), ("peer_isometry", "tab:green")):
                if key in row:
                    ax.plot(row[key]["dt"], abs(row[key]["bias"]), "^", color=colour,
                            mfc="none")
        ax.set_xscale("log")
        ax.set_yscale("log")
    ax.set_xlabel("peer step dt (s)")
    ax.set_ylabel("bias of the variance of the distance at the stop (m^2)")
    ax.set_title("NumPy Euler-Maruyama: measured bias (triangles: chosen dt)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6)

    ax = axes[2]
    rows = [r for r in tta["rows"] if "peer" in r]
    x = np.arange(len(rows))
    c = [r["crandall"]["seconds"] for r in rows]
    ax.bar(x - 0.27, c, 0.27, label="crandall rel_error=R (run)")
    every = list(c)
    for k, (key, colour, label) in enumerate(
            (("peer", "tab:orange", "Euler-Maruyama, sample variance"),
             ("peer_isometry", "tab:green", "Euler-Maruyama, Ito isometry"))):
        for i, r in enumerate(rows):
            if key not in r:
                continue
            y = r[key]["seconds"]
            every.append(y)
            ax.bar(i + 0.27 * k, y, 0.27, color=colour, hatch="" if r[key]["run"] else "//",
                   label=f"{label} (hatched: timed, scaled in paths)" if i == 0 else None)
            ax.annotate(f"x{r[f'ratio_{key}_to_crandall']:.3g}", (i + 0.27 * k, y),
                        ha="center", xytext=(0, 3), textcoords="offset points", fontsize=7)
    ax.set_yscale("log")
    if rows:
        ax.set_ylim(bottom=0.3 * min(every), top=10 * max(every))
    ax.set_xticks(x, [f"R = {r['rel_error']:g}" for r in rows])
    ax.set_ylabel("wall time to the answer (s), 1 thread")
    ax.set_title(f"time to Var S(t_s) within R (relative)\n{tta['scene_file']}", fontsize=10)
    ax.legend(fontsize=7, loc="upper left")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    fig.suptitle(f"crandall {data['crandall']}, piecewise intensity, 1 thread "
                 f"(load {data['machine']['load_before']:.2f})", fontsize=10)
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    main()

"""pytams (trajectory-adaptive multilevel splitting on Euler-Maruyama paths) on the stop
time's far tail, the event crandall.tail estimates: time to a 10 % relative error at
p = 1e-6, and the Euler step bias of the probability.

The event, in scaled units: P(t_s > L) = P(|X(tau0)| >= 2 (L - tau0)), tau0 = 5, X(0) = 0,
dX = -2 sign(X) dt + sqrt(2) dW; exact value S(2 (L - 5); 5) with
S(y; tau) = [erfc((y + 2 tau) / (2 sqrt tau)) + exp(-2 y) erfc((y - 2 tau) / (2 sqrt tau))] / 2
(crandall.analytic.stop_time_sf), and L solved so that it is 1e-6 (L = 8.4233).

Measured, one thread, on a shared machine (wall times move with its load, recorded):

1. pytams as shipped (its asyncio runner with one worker, in-memory database, working
   directory on tmpfs when /dev/shm exists) with the peer model bench/peers/tams_em.py and its
   "committor" score, N trajectories per run, at dt = 0.01 and 0.05 in turn until a time budget
   is spent. Per run: pytams's returned probability, the same estimator recomputed from its
   splitting record without the weight of the last, unfinished iteration (pytams 1.0.0
   multiplies the weight by (1 - b/N) for the iteration at which it finds every trajectory
   converged, before it breaks out of the loop without splitting: tams.py,
   do_multilevel_splitting; a bias of about -b/N on every run that ends that way), the number
   of iterations and the wall time. Per dt: the combined estimate, its standard error from the
   spread of the runs, the relative error reached, and the time to 10 % extrapolated as
   (total time) x (relative error / 0.1)^2 when the budget did not reach it, and as (time per
   run) x (p^(-1/N) - 1) / 0.1^2, the ideal AMS variance (the least any score gives).
2. The Euler step bias without TAMS noise: plain Euler-Maruyama Monte Carlo (NumPy) at
   dt = 0.01 and 0.05 at the levels where the exact probability is 1e-2, 1e-3 and 1e-4.
   (For large |x| the Euler chain is a random walk with drift -2 dt and variance 2 dt, whose
   exponential tail rate solves -2 t + t^2 = 0: 2, the exact rate; the step changes the
   prefactor, so the relative bias is roughly level-independent in the far tail.)
3. Where a pytams run's cost goes: one SQLFile open and close (pytams opens one per task in
   its worker and closes it with a full gc.collect()), and a whole trajectory's steps in-process.
4. Two other scores for the same event at dt = 0.05 (one run each, not statistics; full mode
   only): "velocity"
   (|x| / a) and "stop_time" ((t + |x|/2) / L, which makes pytams stop with "Splitting is
   stalling", see bench/peers/tams_em.py).
5. If crandall is importable: crandall.tail(Scene.scaled(tau0=5, times=[5]), "stop_time", [L],
   rel_error=0.1, threads=1, seed=1), timed in the same process, for the ratio.

pytams is not a dependency of crandall: install it in a separate environment for this bench,

    python3.11 -m venv /tmp/tamsvenv && /tmp/tamsvenv/bin/pip install pytams numpy scipy matplotlib
    /tmp/tamsvenv/bin/pip install .          # optional: crandall itself, for item 5
    /tmp/tamsvenv/bin/python bench/tails_pytams.py [--quick] [--publish] [--budget SECONDS]
        [--trajectories N] [--dt 0.01 ...] [--stem NAME]

Writes bench/out/tails_pytams.{json,png} (or STEM.*); --publish copies both to
bench/results/. Full mode takes about 18 minutes, --quick about a minute (N = 10, one run per
dt). A direct measurement of the time to 10 % at dt = 0.01 (an hour):

    /tmp/tamsvenv/bin/python bench/tails_pytams.py --dt 0.01 --budget 3300 \
        --stem tails_pytams_long --publish
"""

from __future__ import annotations

import argparse
import gc
import logging
import math
import os
import platform
import shutil
import signal
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.optimize import brentq
from scipy.special import erfc

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

TAU0 = 5.0
P_TARGET = 1e-6
TARGET_REL = 0.1
DTS = [0.01, 0.05]
MC_PROBS = [1e-2, 1e-3, 1e-4]


def need_pytams():
    """Import pytams and the peer, or exit with a message that says how to get them."""
    try:
        import pytams  # noqa: F401
        from importlib.metadata import version
        from pytams.tams import TAMS
        from peers.tams_em import SignDriftEM, tams_parameters
    except ImportError as exc:
        sys.exit(f"bench/tails_pytams.py needs pytams, which is installed only for this bench "
                 f"(not a crandall dependency): python3.11 -m venv /tmp/tamsvenv && "
                 f"/tmp/tamsvenv/bin/pip install pytams numpy scipy matplotlib, then run this "
                 f"script with /tmp/tamsvenv/bin/python.\n({exc})")
    return version("pytams"), TAMS, SignDriftEM, tams_parameters


def stop_sf(level: float) -> float:
    """P(t_s > level) = S(2 (level - tau0); tau0), the closed form (double precision is ample
    down to 1e-12 here: no term underflows)."""
    y, tau = 2.0 * (level - TAU0), TAU0
    s = math.sqrt(tau)
    return 0.5 * (erfc((y + 2 * tau) / (2 * s)) + math.exp(-2 * y) * erfc((y - 2 * tau) / (2 * s)))


def level_for(p: float) -> float:
    return brentq(lambda lv: math.log(stop_sf(lv)) - math.log(p), TAU0 + 1e-6, TAU0 + 40.0,
                  xtol=1e-13, rtol=1e-15)


class NoAnswer(Exception):
    """A pytams run stopped by this script's watchdog."""


def _watchdog(limit: float):
    """SIGALRM every half second: raises NoAnswer when the main thread is found twice running
    in the same call of pytams's TAMS.get_restart_at_random (pytams 1.0.0 loops there forever
    when every trajectory has converged with one and the same score: the converged check comes
    after the choice of ancestors, and every index is then among the ones to replace), or when
    the run passes ``limit`` seconds. Returns a function that disarms it."""
    start = time.perf_counter()
    seen = {"frame": None}

    def tick(signum, frame):
        if frame is not None and frame.f_code.co_name == "get_restart_at_random":
            if seen["frame"] is frame:
                raise NoAnswer("hung in TAMS.get_restart_at_random: every trajectory converged "
                               "with the same score")
            seen["frame"] = frame
        else:
            seen["frame"] = None
        if time.perf_counter() - start > limit:
            raise NoAnswer(f"no answer after {limit:.0f} s")

    old = signal.signal(signal.SIGALRM, tick)
    signal.setitimer(signal.ITIMER_REAL, 0.5, 0.5)

    def disarm():
        signal.setitimer(signal.ITIMER_REAL, 0.0, 0.0)
        signal.signal(signal.SIGALRM, old)
    return disarm


def tams_run(TAMS, model, params_fn, *, dt, level, n, score="committor", workroot=None,
             limit=900.0):
    """One pytams run in a fresh working directory; returns its record.

    ``p_returned`` is what compute_probability returned (None when it raised or hung).
    ``p_recomputed`` is the AMS estimator from the run's splitting record, whatever the run's
    end: (product over the finished iterations of (1 - b_i / N)) x (converged / N). After a
    stall (every trajectory with one maximum below the target: the ensemble went extinct) it is
    that weight times the converged fraction, 0 in practice; after the hang it is the weight
    (every trajectory converged). Both are what generalised AMS prescribes, so the mean over
    all runs stays unbiased; dropping the failed runs would not."""
    import toml
    par = params_fn(dt=dt, tau0=TAU0, level=level, trajectories=n, max_iterations=200 * n,
                    score=score)
    cwd = os.getcwd()
    work = tempfile.mkdtemp(prefix="tams_", dir=workroot)
    rec = {"dt": dt, "trajectories": n, "score": score, "ok": True, "p_returned": None}
    tams = None
    try:
        os.chdir(work)
        with open("input.toml", "w") as f:
            toml.dump(par, f)
        start = time.perf_counter()
        disarm = _watchdog(limit)
        try:
            tams = TAMS(fmodel_t=model, a_args=["-i", "input.toml"])
            rec["p_returned"] = float(tams.compute_probability())
        except Exception as exc:  # noqa: BLE001 - a peer's failure is a result here
            rec.update(ok=False, error=f"{type(exc).__name__}: {exc}")
        finally:
            disarm()
            rec["seconds"] = time.perf_counter() - start
        if tams is None:
            return rec
        db = tams.get_database()
        pool = db.get_pool_db()
        biases = np.asarray(pool.get_biases(), dtype=int)
        unfinished = pool.get_ongoing() is not None
        done = biases[:-1] if unfinished and len(biases) else biases
        trajs = db.traj_list()
        n_conv = int(sum(t.is_converged() for t in trajs))
        ended = all(t.has_ended() for t in trajs) and len(trajs) == n
        weight = float(np.prod(1.0 - done / n))
        rec.update(p_recomputed=weight * n_conv / n if ended else None,
                   iterations=int(len(biases)), killed=int(done.sum()), converged=n_conv,
                   last_iteration_unfinished=bool(unfinished),
                   last_bias=int(biases[-1]) if unfinished and len(biases) else 0)
        del db, pool, trajs
        return rec
    finally:
        del tams
        gc.collect()
        os.chdir(cwd)
        shutil.rmtree(work, ignore_errors=True)


def describe(rec: dict) -> str:
    def fmt(v):
        return "-" if v is None else f"{v:.3e}"
    text = (f"p {fmt(rec.get('p_returned'))} returned, {fmt(rec.get('p_recomputed'))} "
            f"recomputed, {rec.get('iterations', '?')} iterations, {rec['seconds']:.1f} s")
    return text if rec["ok"] else f"FAILED ({rec['error']}); {text}"


def summarise(runs, exact, key):
    ok = [r for r in runs if r.get(key) is not None]
    total = sum(r["seconds"] for r in runs)
    out = {"runs": len(runs), "ok_runs": len(ok), "failed_runs": sum(not r["ok"] for r in runs),
           "failures": [r["error"] for r in runs if not r["ok"]], "total_seconds": total}
    if len(ok) < 2:
        return out
    v = np.array([r[key] for r in ok])
    mean, sd = float(v.mean()), float(v.std(ddof=1))
    se = sd / math.sqrt(len(v))
    rel = se / mean if mean > 0 else math.inf
    out.update(mean=mean, sd=sd, stderr=se, rel_error=rel, per_run_rel_sd=sd / mean,
               relative_bias=mean / exact - 1.0, relative_bias_stderr=se / exact,
               seconds_per_run=total / len(runs),
               reached_target=bool(rel <= TARGET_REL),
               seconds_to_target=(total * (rel / TARGET_REL) ** 2))
    # the same with the ideal AMS variance (the committor as score, continuous time): a run's
    # relative variance is p^(-1/N) - 1, the least any score gives with N trajectories
    ideal = exact ** (-1.0 / ok[0]["trajectories"]) - 1.0
    out.update(ideal_per_run_rel_sd=math.sqrt(ideal),
               ideal_seconds_to_target=(total / len(runs)) * ideal / TARGET_REL ** 2)
    # a handful of runs of a right-skewed estimator understates its spread: the larger of the two
    out["seconds_to_target_conservative"] = max(out["seconds_to_target"],
                                                out["ideal_seconds_to_target"])
    # the running combined relative error against cumulative time (for the plot)
    cum, curve = 0.0, []
    vals = []
    for r in runs:
        cum += r["seconds"]
        if r.get(key) is not None:
            vals.append(r[key])
        if len(vals) >= 2:
            a = np.array(vals)
            curve.append([cum, float(a.std(ddof=1) / math.sqrt(len(a)) / a.mean())])
    out["running_rel_error"] = curve
    # the first time the running estimate (of at least 10 runs) was within the target
    first = [t for (t, r), k in zip(curve, range(2, len(curve) + 2)) if k >= 10 and r <= TARGET_REL]
    out["seconds_first_within_target"] = first[0] if first else None
    return out


def plain_mc(dt, paths, levels, seed, batch=1_000_000):
    """Plain Euler-Maruyama: counts of |X(tau0)| >= 2 (L - tau0) for each level."""
    n_steps = round(TAU0 / dt)
    rng = np.random.default_rng(seed)
    thresholds = np.array([2.0 * (lv - TAU0) for lv in levels])
    counts = np.zeros(len(levels), dtype=np.int64)
    sq, step = math.sqrt(2.0 * dt), 2.0 * dt
    start = time.perf_counter()
    for lo in range(0, paths, batch):
        m = min(batch, paths - lo)
        x = np.zeros(m)
        z = np.empty(m)
        for _ in range(n_steps):
            rng.standard_normal(out=z)
            x -= step * np.sign(x)
            x += sq * z
        ax = np.abs(x)
        counts += (ax[None, :] >= thresholds[:, None]).sum(axis=1)
    return counts, time.perf_counter() - start


def cost_breakdown(model, params_fn, level):
    """Seconds for one pytams SQLFile open+close (once per worker task) and per model step of
    a whole trajectory advanced in-process (no runner, no database)."""
    from pytams.sqldb import SQLFile
    from pytams.trajectory import Trajectory
    work = tempfile.mkdtemp(prefix="tams_")
    out = {}
    try:
        f = os.path.join(work, "pool.db")
        SQLFile(f)
        t0 = time.perf_counter()
        for _ in range(5):
            SQLFile(f)
        out["sqlfile_open_close_seconds"] = (time.perf_counter() - t0) / 5
        for dt in DTS:
            par = params_fn(dt=dt, tau0=TAU0, level=level, trajectories=1, max_iterations=1)
            t0 = time.perf_counter()
            steps = 0
            for i in range(20):
                tr = Trajectory(traj_id=i, weight=1.0, fmodel_t=model, parameters=par)
                tr.advance()
                steps += tr.get_computed_steps_count()
            out[f"in_process_seconds_per_step@dt={dt:g}"] = (time.perf_counter() - t0) / steps
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--publish", action="store_true")
    ap.add_argument("--budget", type=float, default=None,
                    help="seconds of pytams runs at dt = 0.01 and 0.05 together (full: 840; "
                         "quick: one run each)")
    ap.add_argument("--trajectories", type=int, default=None,
                    help="TAMS ensemble size N (full: 20, quick: 10)")
    ap.add_argument("--dt", type=float, action="append", choices=DTS,
                    help="run pytams at this step only (repeatable); skips the other scores")
    ap.add_argument("--stem", default="tails_pytams",
                    help="output name under bench/out/ and bench/results/ (default tails_pytams)")
    args = ap.parse_args()
    dts = sorted(set(args.dt)) if args.dt else DTS
    tams_version, TAMS, model, params_fn = need_pytams()
    logging.getLogger("pytams").setLevel(logging.CRITICAL)  # its stall report is recorded here
    n = args.trajectories or (10 if args.quick else 20)
    budget = args.budget if args.budget is not None else (0.0 if args.quick else 840.0)
    mc_paths = {0.01: 200_000, 0.05: 400_000} if args.quick else {0.01: 4_000_000,
                                                                  0.05: 8_000_000}
    workroot = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else None
    t_start = time.perf_counter()

    level = level_for(P_TARGET)
    exact = stop_sf(level)
    out = {"script": "bench/tails_pytams.py",
           "command": " ".join([Path(sys.executable).as_posix(), "bench/tails_pytams.py"]
                               + sys.argv[1:]),
           "pytams_version": tams_version, "numpy_version": np.__version__,
           "python": platform.python_version(), "machine": platform.machine(),
           "load_before": [round(x, 2) for x in os.getloadavg()],
           "tau0": TAU0, "p_target": P_TARGET, "level": level, "exact": exact,
           "trajectories": n, "budget_seconds": budget, "workdir": workroot or tempfile.gettempdir(),
           "runner": "asyncio, nworker_init = nworker_iter = 1",
           "score": "committor", "target_rel_error": TARGET_REL}
    try:
        from crandall import analytic
        out["exact_crandall_analytic"] = float(analytic.stop_time_sf(level, TAU0))
    except ImportError:
        out["exact_crandall_analytic"] = None
    print(f"pytams {tams_version}; L = {level:.6f}, exact P(t_s > L) = {exact:.6e}; "
          f"N = {n}, budget {budget:g} s", flush=True)

    # 2. plain Euler Monte Carlo at moderate levels
    mc_levels = [level_for(p) for p in MC_PROBS]
    mc = {"levels": mc_levels, "exact": [stop_sf(lv) for lv in mc_levels], "runs": {}}
    for i, dt in enumerate(DTS):
        counts, secs = plain_mc(dt, mc_paths[dt], mc_levels, seed=20261125 + i)
        paths = mc_paths[dt]
        est = counts / paths
        se = np.sqrt(est * (1 - est) / paths)
        ex = np.array(mc["exact"])
        mc["runs"][f"{dt:g}"] = {"paths": paths, "seconds": secs, "counts": counts.tolist(),
                                 "estimate": est.tolist(), "stderr": se.tolist(),
                                 "relative_bias": (est / ex - 1).tolist(),
                                 "relative_bias_stderr": (se / ex).tolist()}
        print(f"plain Euler MC dt={dt:g}, {paths:,} paths, {secs:.1f} s: relative bias "
              + ", ".join(f"{b:+.3f} ± {s:.3f} at p={p:g}" for b, s, p in
                          zip(est / ex - 1, se / ex, MC_PROBS)), flush=True)
    out["plain_mc"] = mc

    # 3. where the time goes
    out["cost_breakdown"] = cost_breakdown(model, params_fn, level)
    print("cost breakdown: " + ", ".join(f"{k} {v:.3g}" for k, v in out["cost_breakdown"].items()),
          flush=True)

    # 5. crandall, same event, same process
    try:
        import crandall
        t0 = time.perf_counter()
        r = crandall.tail(crandall.Scene.scaled(tau0=TAU0, times=[TAU0]), "stop_time", [level],
                          rel_error=TARGET_REL, threads=1, seed=1)
        secs = time.perf_counter() - t0
        out["crandall"] = {"version": crandall.__version__, "seconds": secs,
                           "reported_seconds": float(r.seconds),
                           "probability": float(np.ravel(r.probability)[0]),
                           "stderr": float(np.ravel(r.stderr)[0]),
                           "rel_error": float(np.ravel(r.rel_error)[0]),
                           "steps": int(np.sum(r.steps)), "method": r.method,
                           "call": "crandall.tail(crandall.Scene.scaled(tau0=5, times=[5]), "
                                   "'stop_time', [L], rel_error=0.1, threads=1, seed=1)"}
        c = out["crandall"]
        print(f"crandall {c['version']}: {c['probability']:.4e} ± {c['stderr']:.2e} "
              f"(rel {c['rel_error']:.3f}) in {secs:.2f} s", flush=True)
    except ImportError:
        out["crandall"] = None
        print("crandall not importable here: its timing is skipped", flush=True)

    # 4. other scores, a few runs at dt = 0.05 (before the budgeted loop, so they are counted)
    others = []
    extra = [] if args.quick or args.dt else [("stop_time", 1), ("velocity", 1)]
    for score, reps in extra:
        for _ in range(reps):
            rec = tams_run(TAMS, model, params_fn, dt=0.05, level=level, n=n, score=score,
                           workroot=workroot)
            others.append(rec)
            print(f"score {score}: {describe(rec)}", flush=True)
    out["other_scores"] = others

    # 1. pytams, committor score, dt = 0.01 and 0.05 in turn until the budget is spent
    runs = {f"{dt:g}": [] for dt in dts}
    t_loop = time.perf_counter()
    while True:
        progressed = False
        for dt in dts:
            mine = runs[f"{dt:g}"]
            spent = time.perf_counter() - t_loop
            guess = (sum(r["seconds"] for r in mine) / len(mine)) if mine else 0.0
            if mine and spent + guess > budget:
                continue
            rec = tams_run(TAMS, model, params_fn, dt=dt, level=level, n=n, workroot=workroot)
            mine.append(rec)
            progressed = True
            print(f"dt={dt:g} run {len(mine)}: {describe(rec)}", flush=True)
        if not progressed or budget <= 0:
            break
    out["tams_runs"] = runs
    out["tams"] = {dt: {"returned": summarise(rs, exact, "p_returned"),
                        "recomputed": summarise(rs, exact, "p_recomputed")}
                   for dt, rs in runs.items()}
    out["seconds"] = time.perf_counter() - t_start
    out["load_after"] = [round(x, 2) for x in os.getloadavg()]

    print(f"\nexact P = {exact:.4e} at L = {level:.5f}")
    for dt, s in out["tams"].items():
        for key in ("recomputed", "returned"):
            v = s[key]
            if "mean" not in v:
                print(f"pytams dt={dt} ({key}): {v['ok_runs']} good runs of {v['runs']}: "
                      "no estimate")
                continue
            print(f"pytams dt={dt} ({key}): {v['mean']:.4e} ± {v['stderr']:.2e} over "
                  f"{v['ok_runs']} runs (rel. error {v['rel_error']:.3f}, per run "
                  f"{v['per_run_rel_sd']:.2f}), bias {v['relative_bias']:+.3f} ± "
                  f"{v['relative_bias_stderr']:.3f}; {v['total_seconds']:.0f} s; 10 % "
                  + ("reached" if v["reached_target"] else
                     f"not reached, extrapolated {v['seconds_to_target']:.0f} s")
                  + f" (ideal-AMS variance: {v['ideal_seconds_to_target']:.0f} s)")
    if out["crandall"]:
        c = out["crandall"]
        for dt, s in out["tams"].items():
            v = s["recomputed"]
            if "seconds_to_target" in v:
                print(f"time to 10 %: pytams dt={dt} {v['seconds_to_target']:.0f} s from its "
                      f"spread, {v['ideal_seconds_to_target']:.0f} s from the ideal AMS variance, "
                      f"vs crandall {c['seconds']:.1f} s (rel. {c['rel_error']:.3f}): ratios "
                      f"{v['seconds_to_target'] / c['seconds']:.0f} and "
                      f"{v['ideal_seconds_to_target'] / c['seconds']:.0f}")
    print(f"total {out['seconds']:.0f} s")
    write(args.stem, out, plot, publish=args.publish)


def plot(out: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.6), constrained_layout=True)
    colours = {"0.01": "C0", "0.05": "C1"}
    mc = out["plain_mc"]
    for dt, r in mc["runs"].items():
        ax1.errorbar(mc["exact"], r["relative_bias"], yerr=2 * np.array(r["relative_bias_stderr"]),
                     fmt="s-", color=colours[dt], ms=5, capsize=3,
                     label=f"plain Euler MC, dt = {dt} ({r['paths']:,} paths)")
    for dt, s in out["tams"].items():
        off = 1.12 if dt == "0.05" else 0.89
        for key, mk, fill in (("recomputed", "o", True), ("returned", "o", False)):
            v = s[key]
            if "mean" not in v:
                continue
            ax1.errorbar([out["exact"] * off * (1.0 if fill else 1.08)], [v["relative_bias"]],
                         yerr=[2 * v["relative_bias_stderr"]], fmt=mk, color=colours[dt],
                         mfc=colours[dt] if fill else "white", capsize=3,
                         label=f"pytams dt = {dt}, {key} ({v['ok_runs']} runs)")
    if out.get("crandall"):
        c = out["crandall"]
        ax1.errorbar([out["exact"]], [c["probability"] / out["exact"] - 1],
                     yerr=[2 * c["stderr"] / out["exact"]], fmt="*", color="k", ms=10,
                     capsize=3, label="crandall.tail (exact skeleton)")
    ax1.axhline(0, color="k", lw=0.8)
    ax1.set_xscale("log")
    ax1.set_xlabel("exact P(t_s > L)")
    ax1.set_ylabel("estimate / exact - 1  (bars: 2 s.e.)")
    ax1.set_title("Euler step bias of the stop-time tail")
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=7)

    for dt, s in out["tams"].items():
        v = s["recomputed"]
        if "running_rel_error" not in v or not v["running_rel_error"]:
            continue
        cur = np.array(v["running_rel_error"])
        ax2.plot(cur[:, 0], cur[:, 1], "o-", color=colours[dt], ms=4,
                 label=f"pytams dt = {dt}: combined rel. error")
        t_end, r_end = cur[-1]
        t10 = v["seconds_to_target"]
        if not v["reached_target"]:
            ax2.plot([t_end, t10], [r_end, TARGET_REL], "--", color=colours[dt], lw=1,
                     label=f"1/sqrt(t) extrapolation: {t10:,.0f} s to 10 %")
        ti = v["ideal_seconds_to_target"]
        ax2.plot([ti], [TARGET_REL], "x", color=colours[dt], ms=9,
                 label=f"time per run x ideal AMS variance: {ti:,.0f} s")
    if out.get("crandall"):
        c = out["crandall"]
        ax2.plot([c["seconds"]], [c["rel_error"]], "k*", ms=12,
                 label=f"crandall.tail: {c['seconds']:.1f} s")
    ax2.axhline(TARGET_REL, color="k", lw=0.8, ls=":")
    ax2.set_xscale("log")
    ax2.set_yscale("log")
    ax2.set_ylim(0.03, 3.0)
    ax2.set_xlabel("wall seconds (one thread)")
    ax2.set_ylabel("relative error of the combined estimate")
    ax2.set_title(f"Time to 10 % at p = {out['p_target']:g} (pytams {out['pytams_version']}, "
                  f"N = {out['trajectories']})")
    ax2.grid(alpha=0.3, which="both")
    ax2.legend(fontsize=7)
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()

"""The default thread count (every core) against one thread, on an idle machine and on a busy
one (issue 30: with other work on a 2-core machine the default had taken up to 28 times as long
as threads=1).

Four runs of the paper's scene (scaled, tau0 = 5, output at 5), each timed with threads=1 and
with the default, alternately, --repeats times: the stop time's tail at P = 1e-6 (the level of
bench/tails_coverage.py), the distance at the stop's tail at level 51 (P about 1e-9;
rel_error 0.3 by default, a ninth of the default's replicas, to keep the busy case short),
simulate(error=...) and simulate(paths=...). First on the machine as it is ("idle": on a shared
machine other work may run; its load average is recorded), then with --spinners processes of
this script's own that spin on the CPU (started before the busy runs, killed after them
whatever happens, and each ends by itself after --max-busy seconds). The load averages (1, 5,
15 min) are read before and after every run.

Reported per case and condition: the wall seconds of every run, the medians and their ratio
default / threads=1 (the issue's condition: at most 1.10), the CPU seconds of the process.

Writes bench/out/threads_busy.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/threads_busy.py [--repeats 2] [--spinners 4] [--publish]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import signal
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

TAU0 = 5.0
LIMIT = 1.10  # the default may take at most this times threads=1's time
SPIN = "import time\nend = time.monotonic() + {seconds}\nwhile time.monotonic() < end:\n    pass\n"


def cases(args):
    """name -> (what it runs, a function of threads)."""
    import crandall
    from scipy.optimize import brentq
    from crandall import analytic

    scene = crandall.Scene.scaled(tau0=TAU0, times=[TAU0])
    level = brentq(lambda t: math.log(analytic.stop_time_sf(t, TAU0)) - math.log(1e-6), TAU0,
                   40.0, xtol=1e-12)
    return {
        "stop_time tail 1e-6": (
            f"tail(stop_time, [{level:.6g}], seed=1)",
            lambda th: crandall.tail(scene, "stop_time", [level], seed=1, threads=th)),
        "distance tail 1e-9": (
            f"tail(distance_at_stop, [51], rel_error={args.distance_rel_error}, seed=1)",
            lambda th: crandall.tail(scene, "distance_at_stop", [51.0], seed=1, threads=th,
                                     rel_error=args.distance_rel_error)),
        "simulate error=": (
            f"simulate(error={args.error}, seed=1)",
            lambda th: crandall.simulate(scene, error=args.error, seed=1, threads=th)),
        "simulate paths=": (
            f"simulate(paths={args.paths}, seed=1)",
            lambda th: crandall.simulate(scene, paths=args.paths, seed=1, threads=th)),
    }


def timed(run, threads):
    load = os.getloadavg()
    wall, cpu = time.perf_counter(), time.process_time()
    run(threads)
    return {"threads": threads, "seconds": time.perf_counter() - wall,
            "cpu_seconds": time.process_time() - cpu, "load_before": list(load),
            "load_after": list(os.getloadavg())}


def measure(runs, repeats):
    out = {}
    for name, (what, run) in runs.items():
        rows = []
        for _ in range(repeats):
            for threads in (1, None):  # alternately: a change of load hits both
                rows.append(timed(run, threads))
                print(f"  {name:22s} threads={threads!s:4s} {rows[-1]['seconds']:7.2f} s "
                      f"(cpu {rows[-1]['cpu_seconds']:6.2f} s, load {rows[-1]['load_after'][0]:.2f})",
                      flush=True)
        one = statistics.median(r["seconds"] for r in rows if r["threads"] == 1)
        default = statistics.median(r["seconds"] for r in rows if r["threads"] is None)
        out[name] = {"run": what, "runs": rows, "threads1_seconds": one,
                     "default_seconds": default, "ratio": default / one,
                     "load_1min": [r["load_after"][0] for r in rows]}
    return out


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    conds = [(cond, shift) for cond, shift in (("idle", -0.2), ("busy", 0.2))
             if cond in data["conditions"]]
    names = list(data["conditions"][conds[0][0]]["cases"])
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(8, 4.2))
    for k, (cond, shift) in enumerate(conds):
        c = data["conditions"][cond]
        ratios = [c["cases"][n]["ratio"] for n in names]
        loads = [l for n in names for l in c["cases"][n]["load_1min"]]
        ax.bar(x + shift, ratios, 0.4,
               label=f"{cond} (load {min(loads):.1f}-{max(loads):.1f})", color=f"C{k}")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.axhline(LIMIT, color="r", ls="--", lw=0.8, label=f"limit {LIMIT}")
    ax.set_xticks(x, names, fontsize=8)
    ax.set_ylabel("time of the default / time of threads=1")
    ax.set_title(f"{data['cpu_count']} cores; busy: {data['load']['spinners']} spinning processes",
                 fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--spinners", type=int, default=4)
    ap.add_argument("--max-busy", type=float, default=1800.0,
                    help="seconds after which a spinner ends by itself")
    ap.add_argument("--settle", type=float, default=30.0,
                    help="seconds the spinners run before the busy runs start")
    ap.add_argument("--distance-rel-error", type=float, default=0.3)
    ap.add_argument("--error", type=float, default=0.01)
    ap.add_argument("--paths", type=int, default=200_000)
    ap.add_argument("--only", choices=("idle", "busy"), default=None)
    ap.add_argument("--cases", default=None,
                    help="comma-separated words the runs' names must contain (default: all)")
    ap.add_argument("--stem", default="threads_busy", help="the output files' name")
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall

    warnings.simplefilter("ignore")  # a run's statistics warnings are not what is measured
    runs = cases(args)
    if args.cases:
        runs = {k: v for k, v in runs.items() if any(w in k for w in args.cases.split(","))}
    conditions = {}
    if args.only != "busy":
        print("idle (the machine as it is)", flush=True)
        conditions["idle"] = {"cases": measure(runs, args.repeats)}
    if args.only != "idle":
        spinners = [subprocess.Popen([sys.executable, "-c", SPIN.format(seconds=args.max_busy)])
                    for _ in range(args.spinners)]
        # A kill (SIGTERM) ends the script through the finally below, as Ctrl-C does.
        signal.signal(signal.SIGTERM, signal.default_int_handler)
        try:
            time.sleep(args.settle)
            print(f"busy ({args.spinners} spinners, load {os.getloadavg()[0]:.2f})", flush=True)
            conditions["busy"] = {"cases": measure(runs, args.repeats)}
        finally:
            for p in spinners:
                p.kill()
            for p in spinners:
                p.wait()
    data = {
        "crandall_version": crandall.__version__, "cpu_count": os.cpu_count(),
        "machine": platform.machine(), "python": platform.python_version(),
        "limit": LIMIT, "repeats": args.repeats,
        "omp_env": {k: os.environ.get(k) for k in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT",
                                                      "OMP_NUM_THREADS", "KMP_BLOCKTIME")},
        "load": {"spinners": args.spinners, "settle_seconds": args.settle,
                 "how": f"{args.spinners} processes of this script's own, each a Python loop "
                        "spinning on the CPU, started {settle} s before the busy runs and killed "
                        "after them (each would end by itself after max_busy s); other work on "
                        "the machine (it is shared) adds to both conditions: see each run's "
                        "load averages".format(settle=args.settle),
                 "max_busy_seconds": args.max_busy},
        "conditions": conditions,
    }
    for cond, c in conditions.items():
        for name, r in c["cases"].items():
            print(f"{cond:5s} {name:22s} threads=1 {r['threads1_seconds']:7.2f} s  default "
                  f"{r['default_seconds']:7.2f} s  ratio {r['ratio']:.2f}  load "
                  f"{min(r['load_1min']):.1f}-{max(r['load_1min']):.1f}")
    print(write(args.stem, data, plot, publish=args.publish))


if __name__ == "__main__":
    main()

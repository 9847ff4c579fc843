"""Newmark's block on recorded ground motions: crandall against pySLAMMER 0.2.2 on its 18
shipped records, in one process (speeds are compared as ratios measured in the same run: the
machine is shared).

1. Per record, one-way, ky = 0.1 g, normal polarity: the wall time of
   - pySLAMMER: ``RigidAnalysis(0.1, ground_motion)`` (its record already read);
   - crandall exact: ``crandall.newmark(record, ky=0.1)``, the whole Python call with its
     histories and events;
   - crandall slammer: the same with ``method="slammer"``;
   each the median (and the best) of --repeat runs, the three interleaved (each first in turn; the garbage
   collector off while a call is timed, as timeit does); the ratio pySLAMMER / crandall
   exact per record, its median and its smallest value (the issue asks for at least 20x).
2. Agreement: the slammer method against pySLAMMER bit for bit on 18 records x ky 0.05, 0.1,
   0.2 x both polarities (108 cases); pySLAMMER's displacement against the exact method's on
   the same cases (relative difference: median, 90th percentile, largest).
3. A sweep: 100 ky values (0.01 to 0.5 g) x 18 records x 2 polarities (3600 cases) in one
   call of the core, exact and slammer, on one thread and on every core; pySLAMMER on the
   same 3600 cases (a Python loop; --quick times one polarity of 10 ky values and scales it,
   marked so).

Checks that can fail (the script exits with status 1 and does not publish): all 108 cases bit
for bit; the exact method against the reference values of issue 33 to 1e-12; the sweep's
numbers the same on one thread and on every core, and each the same as the case alone.

Writes bench/out/records.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/records.py [--quick] [--publish] [--repeat 15]
"""

from __future__ import annotations

import argparse
import gc
import importlib.resources
import os
import platform
import statistics as pystats
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

import crandall  # noqa: E402
from crandall.records import Record, newmark  # noqa: E402

import pyslammer  # noqa: E402

YIELDS = (0.05, 0.1, 0.2)
SWEEP = np.linspace(0.01, 0.5, 100)
REFERENCE = {"Imperial_Valley_1979_BCR-230": 0.5528877550295594,
             "Kobe_1995_TAK-090": 1.9423588470791866,
             "Northridge_1994_PAC-175": 0.07224120098915005}


def load():
    folder = importlib.resources.files("pyslammer") / "sample_ground_motions"
    out = {}
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(".csv"):
            name = entry.name[:-4]
            with warnings.catch_warnings():  # pySLAMMER's reader leaves its file open
                warnings.simplefilter("ignore", ResourceWarning)
                gm = pyslammer.load_sample_ground_motion(name)
                gc.collect()
            out[name] = (gm, Record.read(str(entry)))
    return out


def timed(f):
    """Wall time of f(), with the garbage collector off (as timeit does: a collection of
    another call's garbage is not charged to this one)."""
    gc.disable()
    try:
        t = time.perf_counter()
        f()
        return time.perf_counter() - t
    finally:
        gc.enable()


def per_record(records, repeat):
    rows = []
    for name, (gm, rec) in records.items():
        calls = {"pyslammer": lambda: pyslammer.RigidAnalysis(0.1, gm),
                 "exact": lambda: newmark(rec, ky=0.1),
                 "slammer": lambda: newmark(rec, ky=0.1, method="slammer")}
        times = {k: [] for k in calls}
        order = list(calls)
        for i in range(repeat):
            for k in order[i % 3:] + order[:i % 3]:  # each goes first in turn
                times[k].append(timed(calls[k]))
        med = {k: pystats.median(v) for k, v in times.items()}
        best = {k: min(v) for k, v in times.items()}
        rows.append({"record": name, "samples": rec.npts, "dt": rec.dt,
                     "seconds": med, "best_seconds": best,
                     "ratio_exact": med["pyslammer"] / med["exact"],
                     "ratio_exact_best": best["pyslammer"] / best["exact"],
                     "ratio_slammer": med["pyslammer"] / med["slammer"]})
        print(f"  {name:34s} {rec.npts:6d} samples  pySLAMMER {med['pyslammer'] * 1e3:7.2f} ms"
              f"  exact {med['exact'] * 1e6:7.1f} us ({rows[-1]['ratio_exact']:5.0f}x)"
              f"  slammer {med['slammer'] * 1e6:7.1f} us", flush=True)
    return rows


def agreement(records, checks):
    names = list(records)
    recs = [records[n][1] for n in names]
    slam = newmark(recs, ky=list(YIELDS), polarity="both", method="slammer").displacement
    exact = newmark(recs, ky=list(YIELDS), polarity="both").displacement
    equal, rel, cases = 0, [], []
    for i, name in enumerate(names):
        for k, ky in enumerate(YIELDS):
            for p, inverse in enumerate((False, True)):
                theirs = pyslammer.RigidAnalysis(ky, records[name][0], inverse=inverse)
                d = theirs.max_sliding_disp
                equal += d == slam[i, k, p]
                if exact[i, k, p] > 0:
                    rel.append(abs(d / exact[i, k, p] - 1))
                    cases.append((name, ky, "inverse" if inverse else "normal", rel[-1]))
    checks.append(("slammer bit for bit with pySLAMMER (108 cases)", equal == 108,
                   f"{equal} of 108"))
    for name, ref in REFERENCE.items():
        got = newmark(records[name][1], ky=0.1).displacement
        checks.append((f"exact {name} ky 0.1 against the reference", abs(got / ref - 1) <= 1e-12,
                       f"{got!r} vs {ref!r}"))
    worst = sorted(cases, key=lambda c: -c[3])[:5]
    return {"bit_for_bit": int(equal), "cases": 108,
            "pyslammer_vs_exact_relative": {
                "cases_with_sliding": len(rel), "median": float(np.median(rel)),
                "p90": float(np.percentile(rel, 90)), "max": float(np.max(rel)),
                "largest": [{"record": c[0], "ky": c[1], "polarity": c[2], "relative": c[3]}
                            for c in worst]}}


def sweep(records, quick, checks):
    recs = [r for _, r in records.values()]
    out = {"ky": SWEEP.tolist(), "records": list(records), "polarities": ["normal", "inverse"]}
    for method in ("exact", "slammer"):
        t1 = timed(lambda: newmark(recs, ky=SWEEP, polarity="both", method=method, threads=1))
        res = {}
        tn = timed(lambda: res.setdefault("r", newmark(recs, ky=SWEEP, polarity="both",
                                                       method=method)))
        one = newmark(recs, ky=SWEEP, polarity="both", method=method, threads=1)
        same = bool(np.array_equal(one.table, res["r"].table))
        alone = newmark(recs[5], ky=float(SWEEP[37]), polarity="inverse", method=method)
        checks.append((f"{method} sweep: threads change nothing; a case alone is the same",
                       same and alone.displacement == one.displacement[5, 37, 1], ""))
        out[method] = {"seconds_1_thread": t1, "seconds_all_threads": tn,
                       "threads": os.cpu_count(),
                       "displacement": one.displacement.tolist()}
        print(f"  {method}: 3600 cases in {t1:.3f} s on 1 thread, {tn:.3f} s on all", flush=True)
    kys = SWEEP[::10] if quick else SWEEP
    pols = (False,) if quick else (False, True)
    t = time.perf_counter()
    for gm, _ in records.values():
        for ky in kys:
            for inverse in pols:
                pyslammer.RigidAnalysis(float(ky), gm, inverse=inverse)
    spent = time.perf_counter() - t
    scale = (len(SWEEP) * 2) / (len(kys) * len(pols))
    out["pyslammer"] = {"seconds": spent * scale, "scaled_from_fraction": 1 / scale}
    print(f"  pySLAMMER: {spent * scale:.1f} s" + (" (scaled)" if scale > 1 else ""), flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats; pySLAMMER's sweep "
                                                          "timed on a tenth and scaled")
    ap.add_argument("--publish", action="store_true")
    ap.add_argument("--repeat", type=int, default=15)
    a = ap.parse_args()
    repeat = min(a.repeat, 3) if a.quick else a.repeat
    started = time.perf_counter()
    out = {"script": "bench/records.py", "command": " ".join(["bench/records.py"] + sys.argv[1:]),
           "crandall": crandall.__version__, "pyslammer": pyslammer.__version__,
           "build": crandall._core.build_info(), "numpy": np.__version__,
           "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                       "processor": platform.processor() or platform.machine(),
                       "load_before": os.getloadavg()[0]}}
    checks = []
    records = load()
    print("1. per record, ky = 0.1", flush=True)
    rows = out["per_record"] = per_record(records, repeat)
    ratios = [r["ratio_exact"] for r in rows]
    best = [r["ratio_exact_best"] for r in rows]
    out["ratio_exact"] = {"median": float(np.median(ratios)), "min": float(np.min(ratios)),
                          "max": float(np.max(ratios)), "target": 20.0,
                          "of_best_times": {"median": float(np.median(best)),
                                            "min": float(np.min(best))}}
    out["ratio_slammer"] = {"median": float(np.median([r["ratio_slammer"] for r in rows]))}
    print(f"  pySLAMMER / exact (median times): median {out['ratio_exact']['median']:.0f}x, "
          f"smallest {out['ratio_exact']['min']:.0f}x (target 20x); of the best times: median "
          f"{np.median(best):.0f}x, smallest {np.min(best):.0f}x", flush=True)
    print("2. agreement", flush=True)
    out["agreement"] = agreement(records, checks)
    print(f"  {out['agreement']['bit_for_bit']} of 108 bit for bit; pySLAMMER vs exact: "
          f"{out['agreement']['pyslammer_vs_exact_relative']}", flush=True)
    print("3. sweep: 100 ky x 18 records x 2 polarities", flush=True)
    out["sweep"] = sweep(records, a.quick, checks)
    out["checks"] = [{"check": c, "passed": bool(ok), "detail": d} for c, ok, d in checks]
    passed = all(ok for _, ok, _ in checks)
    out["checks_passed"] = passed
    out["machine"]["load_after"] = os.getloadavg()[0]
    out["wall_seconds"] = time.perf_counter() - started
    write("records", out, plot, publish=a.publish and passed)
    print(f"{len(checks)} checks, {'all passed' if passed else 'SOME FAILED'}; "
          f"{out['wall_seconds']:.0f} s", flush=True)
    if not passed:
        for c, ok, d in checks:
            if not ok:
                print(f"FAILED: {c} {d}")
        sys.exit(1)


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(14, 5.2), constrained_layout=True)
    ax = axes[0]
    rows = sorted(data["per_record"], key=lambda r: r["samples"])
    n = [r["samples"] for r in rows]
    for key, label, style in (("pyslammer", f"pySLAMMER {data['pyslammer']}", "o-"),
                              ("slammer", "crandall, method slammer", "s-"),
                              ("exact", "crandall, method exact", "^-")):
        ax.loglog(n, [r["seconds"][key] for r in rows], style, ms=4, label=label)
    ax.set_xlabel("samples in the record")
    ax.set_ylabel("wall time per record (s), ky = 0.1 g")
    ax.set_title(f"18 records: pySLAMMER / crandall exact {data['ratio_exact']['median']:.0f}x "
                 f"(median), {data['ratio_exact']['min']:.0f}x (smallest)", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax = axes[1]
    sw = data["sweep"]
    ky = np.array(sw["ky"])
    d = np.array(sw["exact"]["displacement"])
    for i, name in enumerate(sw["records"]):
        for p, ls in ((0, "-"), (1, "--")):
            y = d[i, :, p]
            ok = y > 0
            ax.semilogy(ky[ok], y[ok], ls=ls, lw=0.9, color=f"C{i % 10}",
                        label=name if p == 0 else None)
    ax.set_xlabel("ky (g)")
    ax.set_ylabel("displacement at the record's end (m)")
    ax.set_title(f"exact sweep: 100 ky x 18 records x 2 polarities in "
                 f"{sw['exact']['seconds_all_threads']:.2f} s ({sw['exact']['threads']} "
                 f"threads; pySLAMMER {sw['pyslammer']['seconds']:.0f} s)", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=6, ncol=2, loc="lower left")
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()

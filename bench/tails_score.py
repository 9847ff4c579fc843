"""What splitting's normalised score buys, and where it does not: one replica's relative
spread, skewness and time, with the plain score (the conditional mean, or where the body would
stop now) and with the score normalised towards the level (docs/methods/tails.md, "The score
splitting ranks by, for one level").

Cases, the distance at the stop unless named:
- the paper's scene (scaled, tau0 = 5, the default step) at 51 (P about 1e-9), 30.5 (about
  5e-7) and 15 (about 1e-4); the shipped scene crate's residual displacement at 5.3 m (about 1.3e-9);
- SI scenes (mu = 0.3, the default step): a start at 2 m/s shaken for 1 s (h = 1); two pieces
  (h = 1 then 0.5); a build-up (0.3, 0.6, 1); each at about 1e-4 and 1e-6; and two schedules
  with a lull followed by more shaking, which crandall.tail runs with the plain score: a pause
  (1, 0, 0.5) and the shipped scene aftershock, at about 1e-4; the shipped scene cabinet_amin_ang's
  envelope at about 1e-4 (dt = 0.05 s).
Each replica is crandall.tail's own (its replica function, 200 particles, one thread), the two
scores on the same replica numbers: --replicas for the paper's scene, half for the crate, a
fifth for the others. The work to a given relative error is the spread squared times the
seconds per replica; "rule" is the score crandall.tail picks.

Writes bench/out/tails_score.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/tails_score.py [--replicas 200] [--publish]
"""

from __future__ import annotations

import argparse
import importlib
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

PARTICLES = 200


def replicas(problem, level, n, normalise, key):
    tail = importlib.import_module("crandall.tail")
    est = np.empty(n)
    start = time.perf_counter()
    for r in range(n):
        # normalise=True: the normalised score whatever the schedule (the lulls' cases too).
        e, _ = tail._splitting_replica(problem, np.array([level]), PARTICLES, PARTICLES // 10,
                                       key, r, 1, 10 ** 6, normalise=normalise)
        est[r] = e[0]
    return est, (time.perf_counter() - start) / n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicas", type=int, default=200)
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall
    from crandall import streams

    tail = importlib.import_module("crandall.tail")
    paper = crandall.Scene.scaled(tau0=5.0, times=[5.0])
    crate = crandall.Scene.from_toml("crate")
    few = max(2, args.replicas // 5)

    def si(h, t0, **kw):
        return crandall.Scene(mu=0.3, h=h, t0=t0, times=[1.0], **kw)

    v0, two, build = si(1.0, 1.0, v0=2.0), si([1.0, 0.5], [1.0, 2.0]), si([0.3, 0.6, 1.0], [1.0, 2.0, 3.0])
    pause = si([1.0, 0.0, 0.5], [1.0, 5.0, 6.0])
    after = crandall.Scene.from_toml("aftershock")
    cabinet = crandall.Scene.from_toml("cabinet_amin_ang")
    d = "distance_at_stop"
    cases = (("paper 51", paper, d, 51.0, args.replicas, None),
             ("paper 30.5", paper, d, 30.5, args.replicas, None),
             ("paper 15", paper, d, 15.0, args.replicas, None),
             ("crate residual 5.3 m", crate, "residual_displacement", 5.3,
              max(2, args.replicas // 2), None),
             ("start at 2 m/s 3.77 m", v0, d, 3.77, few, None),
             ("start at 2 m/s 5.5 m", v0, d, 5.5, few, None),
             ("two pieces 0.836 m", two, d, 0.836, few, None),
             ("two pieces 1.6 m", two, d, 1.6, few, None),
             ("build-up 0.883 m", build, d, 0.883, few, None),
             ("build-up 1.7 m", build, d, 1.7, few, None),
             ("pause 0.83 m", pause, d, 0.83, few, None),
             ("aftershock 2.12 m", after, d, 2.12, few, None),
             ("cabinet 0.7 m", cabinet, d, 0.7, few, 0.05))
    key = streams.tail_key(20261126)
    out = {"script": "bench/tails_score.py",
           "command": "python bench/tails_score.py " + " ".join(sys.argv[1:]),
           "crandall_version": crandall.__version__, "particles": PARTICLES, "threads": 1,
           "cases": {}}
    start = time.perf_counter()
    for name, scene, quantity, level, n, dt in cases:
        problem = tail._Problem(scene, quantity, None, dt)
        rule = "plain" if tail._normalised_top(problem, np.array([level])) is None else "normalised"
        rows = {}
        for label, normalise in (("plain", False), ("normalised", True)):
            est, per = replicas(problem, level, n, normalise, key)
            c = est - est.mean()
            spread = float(est.std(ddof=1) / est.mean())
            rows[label] = {"replicas": n, "mean": float(est.mean()),
                           "stderr": float(est.std(ddof=1) / math.sqrt(n)),
                           "relative_spread": spread,
                           "skewness": float(np.mean(c ** 3) / est.std() ** 3),
                           "seconds_per_replica": per, "work": spread ** 2 * per}
            print(f"{name}, {label} score: mean {est.mean():.4g} ± {rows[label]['stderr']:.2g}, "
                  f"relative spread {spread:.3f}, skewness {rows[label]['skewness']:.2f}, "
                  f"{per:.4f} s per replica, work {rows[label]['work']:.4f}", flush=True)
        gain = rows["plain"]["work"] / rows["normalised"]["work"]
        out["cases"][name] = {"quantity": quantity, "level": level, "dt": problem.dt,
                              "rows": rows, "work_ratio_plain_over_normalised": gain,
                              "rule": rule}
        print(f"  work plain / normalised: {gain:.2f}; crandall.tail uses the {rule} score")
    out["seconds"] = time.perf_counter() - start
    write("tails_score", out, plot, publish=args.publish)


def plot(data, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(data["cases"])
    x = np.arange(len(names))
    fig, axes = plt.subplots(2, 1, figsize=(12, 7))
    for k, (label, off) in enumerate((("plain", -0.2), ("normalised", 0.2))):
        rows = [data["cases"][n]["rows"][label] for n in names]
        axes[0].bar(x + off, [r["relative_spread"] for r in rows], 0.4, label=f"{label} score")
        axes[1].bar(x + off, [r["work"] for r in rows], 0.4, label=f"{label} score")
    axes[0].set_ylabel("one replica's relative spread")
    axes[1].set_ylabel("work: spread² × seconds per replica")
    axes[1].set_yscale("log")
    for ax in axes:
        ax.set_xticks(x, [f"{n}\n({data['cases'][n]['rule']})" for n in names], fontsize=7,
                      rotation=30, ha="right")
        ax.grid(True, axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"splitting's score, {data['particles']} particles, one thread", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()

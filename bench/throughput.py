"""Throughput of the kernel: path-steps per second, the random-number floor, observable costs.

Measures, in one run (scaled units, the exact method unless stated):

- the full kernel (velocity, displacement, distance; tau0 = 5, dt = 0.01: 500 steps per path)
  on 1 and 2 threads, in path-steps per second;
- the velocity-only kernel (velocity observed at every step, 500 outputs per path);
- the random-number floor: the same Philox streams and normal/exponential/coin generation, no
  physics (crandall._core.random_floor);
- a velocity-and-stop scene in paths per second at several tau0 (one exact step per path);
- the cost of each observable set at tau0 = 5, dt = 0.01 (velocity; + stop; + displacement;
  + distance; all; all with distributions, with peaks, with both), in paths per second and
  relative to velocity only (bench/distribution_cost.py times the last three against "all"
  directly).

The path-step rates (full kernel, velocity only, random floor) are measured for every kernel
variant the CPU supports (baseline, avx2, avx512: docs/random-numbers.md), each in a subprocess
with CRANDALL_ISA set, and recorded under "variants"; the other figures are for the default
(best) variant. --isa measures one variant only.

Each figure is the best of --repeat runs (the machine is shared: the best run is the least
disturbed one); the load average before and after is recorded. Writes bench/out/throughput.json
and bench/out/throughput.png; --publish copies both to bench/results/.

    .venv/bin/python bench/throughput.py [--quick] [--publish] [--module-path DIR] [--isa NAME]

--module-path runs the same measurements against another build of crandall (e.g. a previous
commit installed with pip --target DIR) for before/after comparisons.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

TAU0 = 5.0
DT = 0.01
STEPS = round(TAU0 / DT)
TARGETS = {"full_1_thread_msteps": 150.0, "two_thread_speedup": 1.8, "floor_factor": 2.0,
           "velocity_stop_mpaths": 30.0}


def where(path: Path) -> str:
    """A path relative to the repository when inside it (results do not name the machine's
    directories)."""
    try:
        return str(path.resolve().relative_to(HERE.parent))
    except ValueError:
        return str(path)


CPU_SECONDS = {}  # the last best_of's best CPU time (all threads of this process)


def best_of(fn, repeat: int) -> float:
    """Best wall-clock time of `repeat` runs; the best CPU time goes to CPU_SECONDS["last"]."""
    best, best_cpu = float("inf"), float("inf")
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    CPU_SECONDS["last"] = best_cpu
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--publish", action="store_true")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--module-path", default=None)
    ap.add_argument("--isa", default=None, help="kernel variant to measure (sets CRANDALL_ISA)")
    ap.add_argument("--rates-only", action="store_true", help=argparse.SUPPRESS)  # child runs
    args = ap.parse_args()
    if args.module_path:
        sys.path.insert(0, args.module_path)
    if args.isa:
        os.environ["CRANDALL_ISA"] = args.isa
    import crandall
    from crandall import _core

    scale = 0.1 if args.quick else 1.0
    paths = int(200_000 * scale)
    load_before = os.getloadavg()
    out = {"script": "bench/throughput.py",
           "command": "python bench/throughput.py" + (" --quick" if args.quick else "")
           + (" --publish" if args.publish else "")
           + (f" --module-path {args.module_path}" if args.module_path else "")
           + (f" --repeat {args.repeat}" if args.repeat != 3 else "")
           + (f" --isa {args.isa}" if args.isa else ""),
           "crandall_version": crandall.__version__, "crandall_path": where(Path(crandall.__file__).parent),
           "machine": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
           "build": _core.build_info() if hasattr(_core, "build_info") else None,
           "tau0": TAU0, "dt": DT, "steps_per_path": STEPS, "paths": paths, "repeat": args.repeat,
           "targets": TARGETS}

    def sim(observe, threads, n=paths, tau0=TAU0, times=None, dt=DT, method="exact",
            distributions=None):
        extra = {} if distributions is None else {"distributions": distributions}
        scene = crandall.Scene.scaled(tau0=tau0, times=times if times is not None else [tau0],
                                      observe=observe, **extra)
        if distributions is not None:
            # The bins' scales (the analytic layer, once per scene) are not the kernel's cost.
            crandall.bins.axes(scene)
        return lambda: crandall.simulate(scene, paths=n, seed=1, dt=dt, method=method,
                                         threads=threads)

    full = ["velocity", "displacement", "distance"]
    rates = {}
    # Path-steps per CPU second of this process: unlike the wall-clock rates, not lowered by
    # other processes taking the cores (on a shared machine the 1-thread figures compare builds
    # more reliably this way; for 2 threads it is the work per CPU second, not a speed).
    cpu_rates = {}
    for threads in (1, 2):
        t = best_of(sim(full, threads), args.repeat)
        rates[f"full_{threads}_thread"] = paths * STEPS / t
        cpu_rates[f"full_{threads}_thread"] = paths * STEPS / CPU_SECONDS["last"]
        print(f"full kernel, {threads} thread(s): {paths * STEPS / t / 1e6:.1f} M path-steps/s", flush=True)
    every_step = [DT * (i + 1) for i in range(STEPS)]
    t = best_of(sim(["velocity"], 1, n=paths // 4, times=every_step), args.repeat)
    rates["velocity_only_1_thread"] = paths // 4 * STEPS / t
    cpu_rates["velocity_only_1_thread"] = paths // 4 * STEPS / CPU_SECONDS["last"]
    print(f"velocity only (output every step), 1 thread: {rates['velocity_only_1_thread'] / 1e6:.1f} M", flush=True)
    if hasattr(_core, "random_floor"):
        for threads in (1, 2):
            t = best_of(lambda: _core.random_floor(paths, STEPS, 1, threads), args.repeat)
            rates[f"random_floor_{threads}_thread"] = paths * STEPS / t
            cpu_rates[f"random_floor_{threads}_thread"] = paths * STEPS / CPU_SECONDS["last"]
            print(f"random floor, {threads} thread(s): {paths * STEPS / t / 1e6:.1f} M", flush=True)
    out["path_steps_per_second"] = rates
    out["path_steps_per_cpu_second"] = cpu_rates
    if args.rates_only:
        print(json.dumps({"build": out["build"], "path_steps_per_second": rates,
                          "path_steps_per_cpu_second": cpu_rates}))
        return
    build = out["build"] or {}
    if "isa_available" in build and not args.isa:
        # The same rates for the other variants, each in a process of its own (the variant is
        # chosen when crandall._core is imported).
        out["variants"] = {build["isa"]: rates}
        out["variants_per_cpu_second"] = {build["isa"]: cpu_rates}
        for isa in build["isa_available"]:
            if isa == build["isa"]:
                continue
            cmd = [sys.executable, str(Path(__file__).resolve()), "--rates-only", "--isa", isa,
                   "--repeat", str(args.repeat)]
            cmd += ["--quick"] if args.quick else []
            cmd += ["--module-path", args.module_path] if args.module_path else []
            print(f"variant {isa}:", flush=True)
            child = subprocess.run(cmd, capture_output=True, text=True, check=True)
            print(child.stdout.rsplit("\n", 2)[0], flush=True)
            measured = json.loads(child.stdout.strip().splitlines()[-1])
            out["variants"][isa] = measured["path_steps_per_second"]
            out["variants_per_cpu_second"][isa] = measured["path_steps_per_cpu_second"]

    stop_rates = {}
    n_stop = int(4_000_000 * scale)
    for tau0 in (0.1, 1.0, 5.0, 50.0):
        t = best_of(sim(["velocity", "stop"], 1, n=n_stop, tau0=tau0), args.repeat)
        stop_rates[f"{tau0:g}"] = n_stop / t
        print(f"velocity+stop, tau0={tau0:g}, 1 thread: {n_stop / t / 1e6:.2f} M paths/s", flush=True)
    out["velocity_stop_paths_per_second_1_thread"] = stop_rates

    costs = {}
    sets = {"velocity": ["velocity"], "+ stop": ["velocity", "stop"],
            "+ displacement": ["velocity", "stop", "displacement"],
            "+ distance": ["velocity", "stop", "distance"],
            "all": ["velocity", "stop", "displacement", "distance"],
            "all + distributions": ["velocity", "stop", "displacement", "distance"],
            "all + peaks": ["velocity", "stop", "displacement", "distance", "peaks"],
            "all + distributions + peaks": ["velocity", "stop", "displacement", "distance",
                                            "peaks"]}
    n_cost = int(100_000 * scale)
    for name, obs in sets.items():
        n = n_cost * (20 if obs in (["velocity"], ["velocity", "stop"]) else 1)
        dist = True if "distributions" in name else None
        try:
            run = sim(obs, 1, n=n, times=[1.0, TAU0], distributions=dist)
        except (TypeError, ValueError) as exc:  # a build (--module-path) without them
            print(f"cost of {name}: not measured ({exc})", flush=True)
            continue
        t = best_of(run, args.repeat)
        costs[name] = {"observe": obs, "paths_per_second": n / t, "seconds_per_million_paths": t / n * 1e6}
        print(f"cost of {name}: {n / t / 1e6:.3f} M paths/s", flush=True)
    base = costs["velocity"]["seconds_per_million_paths"]
    for c in costs.values():
        c["relative_to_velocity"] = c["seconds_per_million_paths"] / base
    out["observable_cost_1_thread"] = costs

    r = rates
    out["against_targets"] = {
        "full_1_thread_msteps": r["full_1_thread"] / 1e6,
        "two_thread_speedup": r["full_2_thread"] / r["full_1_thread"],
        "floor_factor": (r["full_1_thread"] and r.get("random_floor_1_thread", float("nan")) / r["full_1_thread"]),
        "velocity_stop_mpaths_min": min(stop_rates.values()) / 1e6,
    }
    out["load"] = [round(x, 2) for x in load_before]
    out["load_after"] = [round(x, 2) for x in os.getloadavg()]
    print(json.dumps(out["against_targets"], indent=1), "load", out["load"], "->", out["load_after"])
    print("per CPU second:", ", ".join(f"{k} {x / 1e6:.1f} M" for k, x in cpu_rates.items()))
    for isa, v in out.get("variants", {}).items():
        print(f"{isa:>9}: " + ", ".join(f"{k} {x / 1e6:.1f} M" for k, x in v.items()))
        print(f"{'':>9}  per CPU second: " + ", ".join(
            f"{k} {x / 1e6:.1f} M" for k, x in out["variants_per_cpu_second"][isa].items()))

    write("throughput" if not args.module_path else "throughput_other_build", out, plot,
          publish=args.publish)


def plot(out: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    r = dict(out["path_steps_per_second"])
    for isa, v in out.get("variants", {}).items():
        if isa != (out.get("build") or {}).get("isa"):
            r.update({f"{k} [{isa}]": x for k, x in v.items()})
    names = list(r)
    a.barh(names, [r[n] / 1e6 for n in names], color="tab:blue")
    a.axvline(TARGETS["full_1_thread_msteps"], color="tab:red", ls="--", label="target, full kernel 1 thread")
    a.set_xlabel("M path-steps / s")
    a.legend(fontsize=8)
    a.set_title("kernel throughput")
    c = out["observable_cost_1_thread"]
    b.barh(list(c), [v["seconds_per_million_paths"] for v in c.values()], color="tab:green")
    b.set_xscale("log")
    b.set_xlabel("seconds per million paths, 1 thread (tau0 = 5, dt = 0.01)")
    b.set_title("cost of each observable set")
    fig.suptitle(f"crandall {out['crandall_version']}, load {out['load']}")
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()

"""Render the README's "Accuracy and speed" section from the last published bench results.

Reads bench/results/time_to_answer.json and calibration.json (bench/time_to_answer.py and
bench/calibration.py with --publish), bench/results/work_precision.json and
bench/results/throughput.json (written by bench/work_precision.py --publish and
bench/throughput.py --publish) and replaces everything
from the heading "## Accuracy and speed" to the end of README.md. No number is typed by hand.

    .venv/bin/python bench/report.py [--check]

--check exits with status 1 if README.md is not what the JSON files render (for CI).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
HEADING = "## Accuracy and speed"


def fmt_time(s) -> str:
    if s is None:
        return "not reached"
    return f"{s * 1e6:.3g} µs" if s < 1e-3 else f"{s * 1e3:.3g} ms"


def fmt_s(s: float) -> str:
    return f"{s:.2g} s" if s >= 0.01 else f"{s * 1e3:.2g} ms"


def render_time_to_answer() -> list:
    """The time to a requested total error, from time_to_answer.json and calibration.json."""
    path = HERE / "results" / "time_to_answer.json"
    if not path.exists():
        return []
    tta = json.loads(path.read_text())
    lines = [
        "### Time to an answer",
        "",
        "Wall time to reach a total error EPS (discretisation bias and statistical error",
        "together, root mean square) in one statistic of the paper's scene (scaled, tau0 = 5),",
        f"{tta['threads']} thread(s): `simulate(scene, error=EPS)` (multilevel Monte Carlo,",
        "[docs/methods/adaptive.md](docs/methods/adaptive.md)); the fixed-step default",
        "(richardson on the default grid) with the paths its statistical error needs, its bias",
        "ignored; and the Numba Euler-Maruyama peer with the step and paths its measured bias",
        "needs (the step that minimises its time). The fixed-step and peer times are their",
        "measured time per path (or path-step) times the paths they need; the multilevel runs",
        f"were run whenever their predicted time was under {tta['budget_s']:g} s (marked *p*:",
        "predicted from the EPS^-2 law of the same statistic's runs). Made by",
        "",
        "```sh",
        f".venv/bin/python {tta['command']}",
        "```",
        "",
        f"(load average before the run: {tta['machine']['load_before']:.2f})",
        "",
        "![time to answer](bench/results/time_to_answer.png)",
        "",
        "| statistic | EPS | error=EPS | fixed step | Euler peer | fixed step / error=EPS "
        "| peer / error=EPS |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, st in tta["statistics"].items():
        for r in st["rows"]:
            m = r["mlmc"]["seconds"]
            mark = "" if r["mlmc"]["run"] else " *p*"
            fx = r["fixed_step"]["seconds"]
            eu = r.get("euler", {}).get("seconds")
            lines.append(
                f"| {label} | {r['eps']:g} | {fmt_s(m)}{mark} | {fmt_s(fx)} | "
                f"{fmt_s(eu) if eu is not None else 'n/a'} | {fx / m:.2g} | "
                f"{(eu / m) if eu is not None else float('nan'):.3g} |")
    slopes = ", ".join(
        f"{k} {v['mlmc_slope_measured']:.2f} ({v.get('mlmc_slope_finest_two', float('nan')):.2f})"
        for k, v in tta["statistics"].items() if v.get("mlmc_slope_measured"))
    lines += ["", "Fitted slope of log time against log EPS over the runs done (in brackets: "
              f"between the two smallest EPS run, without the pilot's fixed cost): {slopes}.",
              ""]
    cal = HERE / "results" / "calibration.json"
    if cal.exists():
        c = json.loads(cal.read_text())
        lines += [
            f"Calibration ({c['seeds']} seeds, error = {c['error']:g}; "
            f"`.venv/bin/python {c.get('command', 'bench/calibration.py --publish')}`): how "
            "often the analytic value "
            "lies in the reported 95 % interval (95 % if the interval is right; binomial standard deviation "
            f"{100 * c['binomial_sd_of_coverage']:.1f} %):",
            "",
            "| statistic | coverage |",
            "|---|---|",
        ]
        for name, row in c["statistics"].items():
            note = " (error 0: exact identity)" if row["max_error"] == 0 else ""
            lines.append(f"| {name} | {100 * row['coverage']:.1f} %{note} |")
        lines.append("")
    lines += ["Raw numbers: [bench/results/time_to_answer.json](bench/results/time_to_answer.json).",
              "", "### Fixed-step methods", ""]
    return lines


def render() -> str:
    wp = json.loads((HERE / "results" / "work_precision.json").read_text())
    tp = json.loads((HERE / "results" / "throughput.json").read_text())
    lines = [HEADING, ""]
    lines += render_time_to_answer()
    lines += [
        "Bias against `crandall.analytic` versus wall time per path (one thread), for every",
        "method and for Euler-Maruyama written with NumPy and with Numba (`bench/peers/`), in the",
        f"paper's scene (tau0 = {wp['tau0']:g}). Hollow markers are bounds |bias| + 2 SE where the",
        "bias is below 3 standard errors. Made by",
        "",
        "```sh",
        f".venv/bin/{wp['command']}",
        "```",
        "",
        f"(load average before the run: {', '.join(map(str, wp['load']))}; "
        f"{wp['total_seconds'] / 60:.1f} minutes)",
        "",
        "![work-precision](bench/results/work_precision.png)",
        "",
        f"Wall time per path to reach an error of {wp['target_error']:g} in each of the paper's four",
        "curves at tau = 5 (a power-law fit of |bias| against dt through the resolved points, or the",
        "cheapest run whose bound is below the target), and the ratio best peer / best crandall:",
        "",
        "| curve at tau = 5 | best crandall method | its time per path | best peer | its time per path | ratio |",
        "|---|---|---|---|---|---|",
    ]
    for name, r in wp["at_target"].items():
        ours = r["costs"].get(r["best_crandall"]) if r["best_crandall"] else None
        peer = r["costs"].get(r["best_peer"]) if r["best_peer"] else None
        ratio = f"{r['ratio_peer_over_crandall']:.0f}" if r["ratio_peer_over_crandall"] else "n/a"
        lines.append(
            f"| {name.split('@')[0].replace('_', ' ')} | {r['best_crandall'] or 'n/a'} "
            f"({ours['how'] if ours else ''}) | {fmt_time(ours['time_per_path_s'] if ours else None)} "
            f"| {r['best_peer'] or 'not resolved'} | "
            f"{fmt_time(peer['time_per_path_s'] if peer else None)} | {ratio} |")
    below = [name.split("@")[0].replace("_", " ") for name, r in wp["at_target"].items()
             if r["ratio_peer_over_crandall"] is not None and r["ratio_peer_over_crandall"] < 100]
    if below:
        lines += [
            "",
            f"Below the goal of 100: {', '.join(below)}. Why, and what was tried: "
            "[docs/methods/richardson.md](docs/methods/richardson.md#what-limits-the-variance-of-the-distance).",
        ]
    lines += [
        "",
        "Raw numbers, standard errors and the fits: "
        "[bench/results/work_precision.json](bench/results/work_precision.json).",
        "",
        "Throughput (scaled units, exact method, tau0 = "
        f"{tp['tau0']:g}, dt = {tp['dt']:g}: {tp['steps_per_path']} steps per path; best of "
        f"{tp['repeat']} runs; load average before: {', '.join(map(str, tp['load']))}). Made by",
        "",
        "```sh",
        f".venv/bin/{tp['command']}",
        "```",
        "",
        "![throughput](bench/results/throughput.png)",
        "",
        *([f"Kernel variant: {tp['build']['isa']} (of {', '.join(tp['build'].get('isa_available', []))} "
           f"on this CPU), Philox on {tp['build']['philox_paths_per_register']} paths per register, "
           f"random stream {tp['build'].get('random_stream', 1)} (`crandall._core.build_info()`).", ""]
          if tp.get("build") and "isa_available" in tp["build"] else []),
        "| kernel | M path-steps / s |",
        "|---|---|",
    ]
    r = tp["path_steps_per_second"]
    labels = {"full_1_thread": "full (velocity, displacement, distance), 1 thread",
              "full_2_thread": "full, 2 threads",
              "velocity_only_1_thread": "velocity only (output at every step), 1 thread",
              "random_floor_1_thread": "random-number floor (Philox + normal/exponential/coin), 1 thread",
              "random_floor_2_thread": "random-number floor, 2 threads"}
    for k, v in r.items():
        lines.append(f"| {labels.get(k, k)} | {v / 1e6:.1f} |")
    a = tp["against_targets"]
    if tp.get("variants"):
        lines += ["", "Every kernel variant (the same numbers, CRANDALL_ISA forces one; M path-steps / s):", "",
                  "| variant | full, 1 thread | full, 2 threads | velocity only, 1 thread | random floor, 1 thread |",
                  "|---|---|---|---|---|"]
        for isa, v in tp["variants"].items():
            lines.append(f"| {isa} | {v['full_1_thread'] / 1e6:.1f} | {v['full_2_thread'] / 1e6:.1f} | "
                         f"{v['velocity_only_1_thread'] / 1e6:.1f} | {v['random_floor_1_thread'] / 1e6:.1f} |")
    other = HERE / "results" / "throughput_other_build.json"
    if other.exists():
        o = json.loads(other.read_text())
        ob = o["path_steps_per_second"]
        # The folder the other build was in is of the machine that measured it: shown as a
        # placeholder.
        command = re.sub(r"--module-path \S+", "--module-path DIR", o["command"])
        lines += [
            "",
            f"For comparison, crandall {o.get('crandall_version', '?')} "
            f"(build {(o.get('build') or {}).get('isa', 'unknown')}, "
            f"measured by `.venv/bin/{command}`, DIR holding a build of "
            f"{o.get('crandall_version', '?')}): "
            f"{ob['full_1_thread'] / 1e6:.1f} M path-steps/s on 1 thread, "
            f"{ob['full_2_thread'] / 1e6:.1f} M on 2, velocity only "
            f"{ob.get('velocity_only_1_thread', float('nan')) / 1e6:.1f} M, random floor "
            f"{ob.get('random_floor_1_thread', float('nan')) / 1e6:.1f} M "
            "([bench/results/throughput_other_build.json](bench/results/throughput_other_build.json)).",
        ]
        ours = tp["path_steps_per_second"]
        ratios = ", ".join(
            f"{what} {ours[k] / ob[k]:.2f}×" for k, what in (
                ("full_1_thread", "full kernel"), ("velocity_only_1_thread", "velocity only"),
                ("random_floor_1_thread", "random floor")) if k in ours and k in ob)
        lines += ["", f"This build against that one, one thread: {ratios}."]
    lines += [
        "",
        f"Two threads give {a['two_thread_speedup']:.2f}× one thread; the full kernel runs at "
        f"1/{a['floor_factor']:.2f} of the random-number floor.",
        "",
        "| velocity + stop scene, 1 thread | M paths / s |",
        "|---|---|",
    ]
    for tau0, v in tp["velocity_stop_paths_per_second_1_thread"].items():
        lines.append(f"| tau0 = {tau0} | {v / 1e6:.1f} |")
    lines += [
        "",
        "Cost of each observable set (tau0 = 5, outputs at tau = 1 and 5, dt = "
        f"{tp['dt']:g}, 1 thread):",
        "",
        "| observed | s per 10^6 paths | relative to velocity only |",
        "|---|---|---|",
    ]
    for name, c in tp["observable_cost_1_thread"].items():
        lines.append(f"| {name} | {c['seconds_per_million_paths']:.3g} | {c['relative_to_velocity']:.3g} |")
    lines += ["", "Raw numbers: [bench/results/throughput.json](bench/results/throughput.json). "
              "This section is rendered by `.venv/bin/python bench/report.py`.", ""]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args()
    readme = (ROOT / "README.md").read_text()
    head = readme.split(HEADING)[0].rstrip("\n") + "\n\n"
    new = head + render()
    if args.check:
        sys.exit(0 if new == readme else 1)
    (ROOT / "README.md").write_text(new)


if __name__ == "__main__":
    main()

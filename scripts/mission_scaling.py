#!/usr/bin/env python3
"""Times missions of 1, 2, 5 and 10 steps (docs/benchmark.md, "Missions"):
each step a reach through the default scene's first window, back and forth
between a hover before it and one beyond it, planned by quadhand-plan
`--runs` times. Prints, per step count, the median solve time (all legs)
and whole plan after loading (front end + solve + post-check + phase
builds, as the report gives them), and both per step.

Usage: python3 scripts/mission_scaling.py [--build build] [--runs 5] [--steps 1 2 5 10]
Needs the link SDFs of data/tasks/window_cup.yaml (quadhand-sdfgen, as the
README's first command makes them).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
NEAR = "{position: [0.0, 0.0, 1.2], yaw: 3.14159265, joints: [0.3, -0.2, 0.0]}"
BEYOND = "{position: [-1.6, 0.0, 1.2], yaw: 3.14159265, joints: [0.3, -0.2, 0.0]}"


def mission_task(steps):
    text = open(os.path.join(ROOT, "data", "tasks", "window_cup.yaml")).read()
    head = text[: text.index("\ngoal:\n") + 1]
    tail = text[text.index("\nlimits:\n") + 1:]
    head = head.replace("../../", ROOT + "/").replace("../", ROOT + "/data/")
    lines = ["mission:"] + [f"  - reach: {BEYOND if k % 2 == 0 else NEAR}" for k in range(steps)]
    return head + "\n".join(lines) + "\n" + tail


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--steps", type=int, nargs="+", default=[1, 2, 5, 10])
    args = parser.parse_args()
    plan = os.path.join(args.build, "bin", "quadhand-plan")
    print("| steps | solve ms (median) | per step | plan ms after loading (median) | per step | certified |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        for steps in args.steps:
            task = os.path.join(folder, f"mission_{steps}.yaml")
            with open(task, "w") as out:
                out.write(mission_task(steps))
            solves, plans, certified = [], [], 0
            for _ in range(args.runs):
                report = os.path.join(folder, "report.json")
                run = subprocess.run([plan, task, "--out", os.path.join(folder, "plan.csv"), "--report", report],
                                     capture_output=True, text=True)
                if run.returncode not in (0, 1):
                    sys.exit(f"quadhand-plan failed ({run.returncode}): {run.stderr}")
                r = json.load(open(report))
                certified += int(r["success"] and r["certified"])
                solves.append(r["solve_ms"])
                plans.append(r["front_end_ms"] + r["solve_ms"] + r["post_check_ms"] + r.get("mission_phase_build_ms", 0))
            solve, whole = statistics.median(solves), statistics.median(plans)
            print(f"| {steps} | {solve:.1f} | {solve / steps:.1f} | {whole:.1f} | {whole / steps:.1f} | "
                  f"{certified}/{args.runs} |")


if __name__ == "__main__":
    main()

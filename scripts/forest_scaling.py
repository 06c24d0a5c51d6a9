"""Plans random forests known in advance at several lengths and prints how
time and memory grow (docs/perception.md, "Known scenes at scale"): for
each length and seed, scripts/make_forest.py writes the forest and its
task, quadhand-plan plans it, and quadhand-flightcheck judges the plan
against the exact meshes. Reports the process's peak memory (its own
accounting, from wait4), the front end's map build and grid bytes, the
path query, the solve, the whole run, the sections, and the verdicts.

Usage: python3 scripts/forest_scaling.py [--build build] [--lengths 30,100,300] [--seeds 1,2,3]
Needs the link SDFs (data/sdf/quadhand: the README's first command makes them).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def run(argv):
    """Runs argv; returns (exit code, peak resident KB, wall seconds, stdout)."""
    start = time.monotonic()
    child = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    out = child.stdout.read()
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    return child.returncode, usage.ru_maxrss, time.monotonic() - start, out.decode(errors="replace")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default="build")
    parser.add_argument("--lengths", default="30,100,300")
    parser.add_argument("--seeds", default="1,2,3")
    args = parser.parse_args()
    plan = os.path.join(ROOT, args.build, "bin", "quadhand-plan")
    check = os.path.join(ROOT, args.build, "bin", "quadhand-flightcheck")
    for tool in (plan, check):
        if not os.access(tool, os.X_OK):
            sys.exit(f"forest_scaling: {tool} is missing")
    print("| length, m | seed | exit | certified | flightcheck | peak memory, MB | front-end map, ms | grid, MB "
          "| path query, ms | solve, ms | sections | whole run, s | plan duration, s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as work:
        for length in [float(x) for x in args.lengths.split(",")]:
            for seed in [int(x) for x in args.seeds.split(",")]:
                subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "make_forest.py"), "--length",
                                f"{length:g}", "--seed", str(seed), "--out", work], check=True,
                               stdout=subprocess.DEVNULL)
                stem = os.path.join(work, f"forest_L{length:g}_s{seed}")
                code, peak_kb, wall, out = run([plan, stem + ".yaml", "--out", stem + ".csv", "--report",
                                                stem + ".json"])
                if not os.path.exists(stem + ".json"):
                    print(f"| {length:g} | {seed} | {code} | - | - | {peak_kb / 1024:.0f} | - | - | - | - | - | "
                          f"{wall:.2f} | - | {out.strip().splitlines()[-1][:120]}")
                    continue
                r = json.load(open(stem + ".json"))
                verdict = "-"
                if code == 0:
                    judged = subprocess.run([check, stem + ".yaml", stem + ".csv", "--json"], capture_output=True,
                                            text=True)
                    j = json.loads(judged.stdout)
                    verdict = f"{'kept' if j['kept'] else 'LOST'} {100 * j['min_clearance']:.2f} cm"
                print(f"| {length:g} | {seed} | {code} | {r['certified']} | {verdict} | {peak_kb / 1024:.0f} | "
                      f"{r['front_end_build_ms']:.0f} | {r['front_end_grid_bytes'] / 1e6:.1f} | "
                      f"{r['front_end_ms']:.1f} | {r['solve_ms']:.0f} | {r.get('sections', 0)} | {wall:.2f} | "
                      f"{r['duration_s']:.1f} |" + ("" if r["success"] else " " + r["message"][:120]))
                os.remove(stem + ".pcd")


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Merges quadhand-bench results (one or more JSONL files, e.g. from shards)
into a Markdown table like the paper's Fig. 4G and PNG plots.

Usage: scripts/bench_report.py results*.jsonl [--out report.md] [--plots DIR]
Rows are (representation, solver), and with a moving target (the
moving-cup benchmark) also its speed; a trial counts once per row even if it
appears in several files (duplicates are an error: shards must not overlap).
"""
import os
import sys

try:
    import matplotlib
except ImportError:  # a Python without Debian's matplotlib (e.g. pyenv): use the system one
    if sys.executable != "/usr/bin/python3" and os.path.exists("/usr/bin/python3"):
        os.execv("/usr/bin/python3", ["/usr/bin/python3"] + sys.argv)
    raise

import argparse
import json
import statistics

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def percentile(values, p):
    if not values:
        return float("nan")
    v = sorted(values)
    i = p * (len(v) - 1)
    lo = int(i)
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (i - lo) * (v[hi] - v[lo])


def load(paths):
    rows = {}
    for path in paths:
        with open(path) as f:
            for number, line in enumerate(f, 1):
                if not line.strip():
                    continue
                try:
                    r = json.loads(line)
                    key = (r["representation"], r["solver"], r["trial"])
                except (ValueError, KeyError) as e:
                    sys.exit(f"bench_report: {path}:{number}: not a quadhand-bench result line ({e})")
                if key in rows:
                    sys.exit(f"bench_report: {path}:{number}: trial {key[2]} of {key[0]} + {key[1]} appears twice")
                rows[key] = r
    if not rows:
        sys.exit("bench_report: no results in " + ", ".join(paths))
    return rows


def summarise(rows):
    groups = {}
    for (representation, solver, _), r in sorted(rows.items(), key=lambda kv: kv[0]):
        speed = r.get("target", {}).get("speed_mps")
        groups.setdefault((representation, solver, speed), []).append(r)
    table = []
    for (representation, solver, speed), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1], kv[0][2] or 0)):
        ok = [r for r in rs if r["success"]]
        solve = [r["solve_ms"] for r in ok]
        errors = [1e3 * r["tool_to_target_m"] for r in ok if "tool_to_target_m" in r]
        table.append({
            "representation": representation,
            "solver": solver if speed is None else f"{solver} @ target {speed:.2f} m/s",
            "trials": len(rs), "successes": len(ok),
            "certified": sum(1 for r in ok if r.get("certified")),
            "tool_error": (f"{percentile(errors, 0.5):.2f} / {max(errors):.2f}" if errors else "-"),
            "solve": solve,
            "solve_mean": statistics.mean(solve) if solve else float("nan"),
            "solve_median": percentile(solve, 0.5), "solve_p95": percentile(solve, 0.95),
            "build": statistics.mean([r.get("representation_build_ms", float("nan")) for r in rs]),
            "front": percentile([r["front_end_ms"] for r in rs if "front_end_ms" in r], 0.5),
            "iterations": percentile([r["iterations"] for r in ok], 0.5),
            "evaluations": percentile([r["cost_evaluations"] for r in ok], 0.5),
            "clear_min": min((r["min_clearance_exact_m"] for r in ok), default=float("nan")),
            "clear_median": percentile([r["min_clearance_exact_m"] for r in ok], 0.5),
        })
    return table


def markdown(table, paths):
    out = ["| representation | solver | success | certified | optimisation ms (mean / median / p95, successes) | "
           "representation build ms (mean) | front end ms (median) | iterations / evaluations (median) | "
           "exact clearance m (min / median) | tool to target mm (median / max) |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for t in table:
        out.append(f"| {t['representation']} | {t['solver']} | {t['successes']}/{t['trials']} "
                   f"({100.0 * t['successes'] / t['trials']:.0f} %) | {t['certified']}/{t['trials']} | "
                   f"{t['solve_mean']:.1f} / {t['solve_median']:.1f} / "
                   f"{t['solve_p95']:.1f} | {t['build']:.1f} | {t['front']:.2f} | {t['iterations']:.0f} / "
                   f"{t['evaluations']:.0f} | {t['clear_min']:.4f} / {t['clear_median']:.4f} | {t['tool_error']} |")
    out.append("")
    out.append("From: " + ", ".join(os.path.basename(p) for p in paths))
    return "\n".join(out) + "\n"


def plots(table, directory):
    os.makedirs(directory, exist_ok=True)
    labels = [f"{t['representation']}\n{t['solver']}" for t in table]
    fig, ax = plt.subplots(figsize=(max(4, 1.6 * len(table)), 3.5))
    ax.bar(labels, [100.0 * t["successes"] / t["trials"] for t in table], color="#4a90d9")
    ax.set_ylabel("success rate (%)")
    ax.set_ylim(0, 100)
    ax.set_title("Window-and-cup benchmark: success")
    fig.tight_layout()
    fig.savefig(os.path.join(directory, "bench_success.png"), dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(max(4, 1.6 * len(table)), 3.5))
    data = [t["solve"] if t["solve"] else [float("nan")] for t in table]
    ax.boxplot(data, whis=(5, 95), showfliers=True)
    ax.set_xticks(range(1, len(labels) + 1), labels)
    ax.set_ylabel("optimisation time (ms), successful trials")
    ax.set_yscale("log")
    ax.set_title("Window-and-cup benchmark: optimisation time")
    fig.tight_layout()
    fig.savefig(os.path.join(directory, "bench_times.png"), dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="+", help="quadhand-bench JSONL files")
    parser.add_argument("--out", help="write the Markdown table here (default: stdout)")
    parser.add_argument("--plots", help="write bench_success.png and bench_times.png into this folder")
    args = parser.parse_args()
    for path in args.results:
        if not os.path.isfile(path):
            sys.exit(f"bench_report: {path}: no such file")
    table = summarise(load(args.results))
    text = markdown(table, args.results)
    if args.out:
        with open(args.out + ".tmp", "w") as f:
            f.write(text)
        os.replace(args.out + ".tmp", args.out)
    else:
        sys.stdout.write(text)
    if args.plots:
        plots(table, args.plots)


if __name__ == "__main__":
    main()

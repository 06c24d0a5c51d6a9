#!/usr/bin/python3
"""The paper's figure-eight experiment (Sec. VII-B) in the simulator.

Writes the 3.6 m x 2 m figure-eight plan with sinusoidal joint motion
(quadhand-sim --figure8), flies it in four configurations (PCGC on/off x
payload 0 / 0.15 kg), three seeded trials of three loops each, and writes
docs/figure8.md (3-D absolute tracking error per configuration, CoG offsets)
and docs/figure8.png (box plot). Flown files go to out/figure8/.

Usage: scripts/figure8.py [--sim build/bin/quadhand-sim] [--out-dir out/figure8] [--docs docs]
Needs Debian's python3-matplotlib (scripts/setup.sh installs it).
"""
import os
import sys

try:
    import matplotlib
except ImportError:  # e.g. a pyenv python3 first on PATH: use Debian's, which has it
    if sys.executable != "/usr/bin/python3" and os.path.exists("/usr/bin/python3"):
        os.execv("/usr/bin/python3", ["/usr/bin/python3"] + sys.argv)
    sys.exit("figure8.py: needs matplotlib (Debian: apt-get install python3-matplotlib)")

import argparse
import csv
import math
import statistics
import subprocess

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIGS = [  # (label, pcgc, payload kg)
    ("PCGC on, no payload", "on", 0.0),
    ("PCGC off, no payload", "off", 0.0),
    ("PCGC on, payload 0.15 kg", "on", 0.15),
    ("PCGC off, payload 0.15 kg", "off", 0.15),
]
SEEDS = [1, 2, 3]
LOOPS = 3
PERIOD = 10.0
SETTLE = 3.0


def run(cmd):
    result = subprocess.run(cmd, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit("figure8.py: %s failed (exit %d): %s" % (" ".join(cmd), result.returncode, result.stderr.strip()))
    return result.stdout


def quantile(sorted_values, p):
    x = p * (len(sorted_values) - 1)
    i = int(math.floor(x))
    j = min(i + 1, len(sorted_values) - 1)
    return sorted_values[i] + (x - i) * (sorted_values[j] - sorted_values[i])


def read_flown(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    col = lambda name: [float(r[name]) for r in rows]  # noqa: E731
    return {name: col(name) for name in ("err_pos", "cog_x", "cog_y", "cog_z", "arm_ty", "joint1")}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sim", default=os.path.join(ROOT, "build", "bin", "quadhand-sim"))
    parser.add_argument("--config", default=os.path.join(ROOT, "data", "sim", "quadhand_sim.yaml"))
    parser.add_argument("--out-dir", default=os.path.join(ROOT, "out", "figure8"))
    parser.add_argument("--docs", default=os.path.join(ROOT, "docs"))
    args = parser.parse_args()
    if not os.access(args.sim, os.X_OK):
        sys.exit("figure8.py: %s not found; build it first (bash scripts/build.sh quadhand-sim)" % args.sim)
    os.makedirs(args.out_dir, exist_ok=True)
    os.makedirs(args.docs, exist_ok=True)

    plan = os.path.join(args.out_dir, "figure8_plan.csv")
    run([args.sim, "-q", "--config", args.config, "--figure8", "--loops", str(LOOPS), "--period", str(PERIOD),
         "--out", plan])

    with open(plan, newline="") as f:
        plan_rows = list(csv.DictReader(f))
    peak_speed = max(math.sqrt(sum(float(r[k]) ** 2 for k in ("vx", "vy", "vz"))) for r in plan_rows)
    peak_acc = max(math.sqrt(sum(float(r[k]) ** 2 for k in ("ax", "ay", "az"))) for r in plan_rows)

    results = []
    for label, pcgc, payload in CONFIGS:
        errors, trial_means, flights = [], [], []
        for seed in SEEDS:
            flown = os.path.join(args.out_dir, "flown_pcgc-%s_payload-%g_seed-%d.csv" % (pcgc, payload, seed))
            run([args.sim, "-q", "--config", args.config, "--track", plan, "--out", flown, "--pcgc", pcgc,
                 "--payload", str(payload), "--seed", str(seed), "--noise", "on", "--settle", str(SETTLE)])
            data = read_flown(flown)
            errors += data["err_pos"]
            trial_means.append(statistics.fmean(data["err_pos"]))
            flights.append(data)
        s = sorted(errors)
        first = flights[0]
        cog_xy = [math.hypot(x, y) for x, y in zip(first["cog_x"], first["cog_y"])]
        results.append({
            "label": label, "errors": errors, "mean": statistics.fmean(errors), "median": quantile(s, 0.5),
            "p95": quantile(s, 0.95), "max": s[-1], "trial_means": trial_means,
            "cog_mean": statistics.fmean(cog_xy), "cog_max": max(cog_xy),
            "cog_x_min": min(first["cog_x"]), "cog_x_max": max(first["cog_x"]),
            "cog_x_std": statistics.pstdev(first["cog_x"]),
            "arm_ty_mean": statistics.fmean(first["arm_ty"]), "arm_ty_std": statistics.pstdev(first["arm_ty"]),
            "q1_min": min(first["joint1"]), "q1_max": max(first["joint1"]),
        })

    # Box plot of the pooled 3-D errors.
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.boxplot([[100 * e for e in r["errors"]] for r in results], whis=(5, 95), showfliers=False)
    ax.set_xticks(range(1, len(results) + 1))
    ax.set_xticklabels([r["label"].replace(", ", "\n") for r in results])
    ax.set_ylabel("3-D absolute tracking error (cm)")
    ax.set_title("Figure eight 3.6 m x 2 m, %d trials x %d loops per configuration (simulated)" % (len(SEEDS), LOOPS))
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    png = os.path.join(args.docs, "figure8.png")
    fig.savefig(png + ".tmp.png", dpi=110)
    os.replace(png + ".tmp.png", png)

    by = {r["label"]: r for r in results}
    def gain(payload_label):
        on, off = by["PCGC on, " + payload_label], by["PCGC off, " + payload_label]
        return 100.0 * (off["mean"] - on["mean"]) / off["mean"], on, off
    g0, on0, off0 = gain("no payload")
    g1, on1, off1 = gain("payload 0.15 kg")
    helps = g0 > 0 and g1 > 0
    q1_lo, q1_hi = results[0]["q1_min"], results[0]["q1_max"]

    lines = [
        "# Figure-eight tracking in the simulator",
        "",
        "Generated by `scripts/figure8.py` (do not edit by hand): the paper's experiment (Sec. VII-B)",
        "flown by `quadhand-sim` (model and controller: [sim.md](sim.md)). The base follows a",
        "3.6 m x 2 m figure eight at 1.2 m height, %d loops of %g s each (plus a 2 s ramp up and down;"
        % (LOOPS, PERIOD),
        "peak speed %.2f m/s, peak acceleration %.2f m/s^2), while the joints move sinusoidally within their"
        % (peak_speed, peak_acc),
        "limits",
        "(joint1 %.2f..%.2f rad, period 4 s; joint2 +-0.8 rad, 5 s; joint3 +-1.2 rad, 3 s). Each"
        % (q1_lo, q1_hi),
        "configuration is flown %d times with seeded sensor noise (seeds %s) after %g s of hover;"
        % (len(SEEDS), ", ".join(map(str, SEEDS)), SETTLE),
        "statistics pool the 3-D absolute position error of the base of all trials, sampled every 0.01 s.",
        "",
        "| configuration | mean (cm) | median (cm) | p95 (cm) | max (cm) | per-trial means (cm) |",
        "|---|---|---|---|---|---|",
    ]
    for r in results:
        lines.append("| %s | %.2f | %.2f | %.2f | %.2f | %s |" % (
            r["label"], 100 * r["mean"], 100 * r["median"], 100 * r["p95"], 100 * r["max"],
            ", ".join("%.2f" % (100 * m) for m in r["trial_means"])))
    lines += [
        "",
        "![3-D tracking error per configuration](figure8.png)",
        "",
        "Box: quartiles; whiskers: 5th and 95th percentiles.",
        "",
        "## CoG offset during the flight",
        "",
        "The whole vehicle's centre of gravity in the base frame (relative to the rotor centre) and",
        "the pitch torque the arm (with battery and payload) exerts on the base about the rotor",
        "centre, from the flown files (seed %d): their range or mean, and their standard deviation over"
        % SEEDS[0],
        "the flight, i.e. how much they vary while the arm moves:",
        "",
        "| configuration | CoG x range (mm) | CoG x std (mm) | mean / max horizontal CoG offset (mm) "
        "| arm pitch torque mean / std (N m) |",
        "|---|---|---|---|---|",
    ]
    for r in results:
        lines.append("| %s | %.1f .. %.1f | %.1f | %.1f / %.1f | %.3f / %.3f |" % (
            r["label"], 1000 * r["cog_x_min"], 1000 * r["cog_x_max"], 1000 * r["cog_x_std"], 1000 * r["cog_mean"],
            1000 * r["cog_max"], r["arm_ty_mean"], r["arm_ty_std"]))
    lines += [
        "",
        "## What the simulation gives",
        "",
        ("PCGC %s the mean error by %.0f %% without payload (%.2f -> %.2f cm) and by %.0f %% with the"
         % ("lowers" if g0 > 0 else "does not lower", abs(g0), 100 * off0["mean"], 100 * on0["mean"], abs(g1))),
        ("0.15 kg payload (%.2f -> %.2f cm). %s"
         % (100 * off1["mean"], 100 * on1["mean"],
            "So PCGC helps here, as in the paper (errors there: 3-4 cm)." if helps else
            "So in this simulation PCGC does not help in every configuration.")),
        "",
        "Why: the controller, like a real autopilot, does not know the arm. The CoG offset is a",
        "torque m g x_CoG on the base; the controller's integrators cancel its slow part, but only",
        "after the attitude (and so the position) has moved, so what costs tracking accuracy is how",
        "fast and how far the offset changes while the arm moves, not its mean. With the battery on",
        "its mimic joint the battery swings down as joint1 lowers the arm, so the horizontal CoG",
        "moves %.1f mm per unit of cos(joint1) instead of %.1f mm (robot.md: the arm's moment about"
        % (1000 * 0.07265 / 1.7, 1000 * 0.0939 / 1.7),
        "joint1 is 0.0939 kg m, the battery's 0.02125 kg m): a 23 % smaller swing. In this flight the",
        "CoG x standard deviation drops from %.1f to %.1f mm (%.1f to %.1f mm with the payload) and"
        % (1000 * off0["cog_x_std"], 1000 * on0["cog_x_std"], 1000 * off1["cog_x_std"], 1000 * on1["cog_x_std"]),
        "that of the arm's pitch torque from %.3f to %.3f N m (%.3f to %.3f N m). The counter-rotating"
        % (off0["arm_ty_std"], on0["arm_ty_std"], off1["arm_ty_std"], on1["arm_ty_std"]),
        "battery also cancels about 9 % of the arm's reaction torque when joint1 accelerates",
        "(tests/sim/dynamics_test.cc). The mean offset is not smaller with PCGC: the battery hanging",
        "down shortens its backward lever, so at every joint1 angle the CoG sits further forward than",
        "with the battery locked straight back, by 12.5 (1 - cos(joint1)) mm, which is closer to the",
        "rotor centre only when the arm hangs almost straight down (joint1 above about 1.42 rad; fully",
        "lowered, within about 1 mm against 13.6 mm behind). Here the mean horizontal offset is %.1f"
        % (1000 * on0["cog_mean"]),
        "mm with PCGC against %.1f mm without. With the arm forward both are the same (%.0f mm,"
        % (1000 * off0["cog_mean"], 1000 * on0["cog_x_max"]),
        "%.0f mm with the payload)." % (1000 * on1["cog_x_max"]),
        "The payload makes every offset and swing larger, hence the larger errors, and PCGC's relative",
        "gain smaller (it does not compensate the payload). The sensor noise is small next to the",
        "arm's disturbance: the mean errors of the trials of a configuration differ by at most %.2f mm."
        % (1000 * max(max(r["trial_means"]) - min(r["trial_means"]) for r in results)),
        "",
        "Reproduce: `bash scripts/build.sh quadhand-sim && scripts/figure8.py` (about half a minute).",
        "",
    ]
    md = os.path.join(args.docs, "figure8.md")
    with open(md + ".tmp", "w") as f:
        f.write("\n".join(lines))
    os.replace(md + ".tmp", md)
    for r in results:
        print("%-28s mean %.2f cm  median %.2f  p95 %.2f  max %.2f" % (
            r["label"], 100 * r["mean"], 100 * r["median"], 100 * r["p95"], 100 * r["max"]))
    print("wrote %s and %s" % (md, png))


if __name__ == "__main__":
    main()

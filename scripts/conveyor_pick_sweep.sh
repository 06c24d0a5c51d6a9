#!/usr/bin/env bash
# Plans the bundled moving-belt mission (data/tasks/missions/conveyor_pick.yaml,
# docs/moving_targets.md "In a mission") with the belt at other velocities,
# judges every plan with quadhand-flightcheck (the belt's points where the
# plan's target columns put them), and prints a table. Needs the link SDFs
# (data/sdf/quadhand: the README's first command makes them).
# Usage: bash scripts/conveyor_pick_sweep.sh [BUILD_DIR] [VELOCITY ...]
#   each VELOCITY as "vx, vy, vz" (m/s); default: a set along and across the belt.
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build}"
shift || true
for tool in quadhand-plan quadhand-flightcheck; do
  if [[ ! -x "$build/bin/$tool" ]]; then echo "conveyor_pick_sweep: $build/bin/$tool is missing" >&2; exit 2; fi
done
velocities=("$@")
if [[ ${#velocities[@]} == 0 ]]; then
  velocities=("0, 0.05, 0" "0, 0.1, 0" "0, -0.1, 0" "0.05, 0, 0" "-0.05, 0.05, 0" "0, 0.1, 0.02" "0, 0.15, 0" "0, 0.3, 0")
fi
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
root="$(pwd)"
echo "| belt velocity, m/s | exit | arrival, s | plan duration, s | solve, ms | phases, ms | total, ms | tool to cup at the arrival, mm | flightcheck: robot, held object (cm) | why not |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for v in "${velocities[@]}"; do
  sed -e "s/velocity: \[0.0, 0.1, 0.0\]/velocity: [$v]/" -e "s#\.\./\.\./\.\./#$root/#" -e "s#\.\./\.\./#$root/data/#" \
    data/tasks/missions/conveyor_pick.yaml > "$out/task.yaml"
  set +e
  "./$build/bin/quadhand-plan" "$out/task.yaml" --out "$out/plan.csv" --report "$out/report.json" > "$out/plan.txt" 2>&1
  code=$?
  judged="-"
  if [[ $code == 0 ]]; then
    judged="$("./$build/bin/quadhand-flightcheck" "$out/task.yaml" "$out/plan.csv" --json)"
  fi
  set -e
  if [[ ! -f "$out/report.json" ]]; then
    echo "| [$v] | $code | - | - | - | - | - | - | - | $(tail -1 "$out/plan.txt" | cut -c1-160) |"
    continue
  fi
  python3 - "$v" "$code" "$judged" "$out/report.json" <<'PY'
import json, sys
velocity, code, judged, path = sys.argv[1:5]
r = json.load(open(path))
m = r.get("moving_target", {})
verdict = "-"
if judged != "-":
    j = json.loads(judged)
    verdict = "%s %.2f, %.2f" % ("kept" if j["kept"] else "LOST", 100 * j["min_clearance"],
                                 100 * j["held_object_min_clearance"] if j["held_object_min_clearance"] is not None else float("nan"))
print("| [%s] | %s | %s | %.2f | %.1f | %.1f | %.1f | %s | %s | %s |" % (
    velocity, code, "%.2f" % m["arrival_s"] if "arrival_s" in m else "-", r["duration_s"], r["solve_ms"],
    r.get("mission_phase_build_ms", 0.0), r["total_ms"],
    "%.3f" % (1000 * m["tool_to_target_m"]) if "tool_to_target_m" in m else "-", verdict,
    "" if r["success"] else r["message"][:160]))
PY
  rm -f "$out/report.json"
done

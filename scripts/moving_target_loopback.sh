#!/usr/bin/env bash
# quadhand-online grasping a moving cup over the loopback link, in real time
# (docs/moving_targets.md, "Online"): for each seed, quadhand-sim moves the
# cup of data/tasks/conveyor_cup.yaml (0.3 m/s along y) and sends its pose as
# LANDING_TARGET at 30 Hz with 5 mm of noise (0.02 rad on the heading),
# passing its place in the task 11 to 13 s into the run (by seed); the
# vehicle knows only the measurements. Each flight is then judged on the
# simulator's own record against where the cup truly was
# (quadhand-flightcheck, the record's target_* columns): the least exact
# clearance up to quadhand-online's end, and the tool's true distance from
# the cup at the plan's arrival.
#   scripts/moving_target_loopback.sh [--flights N] [--first-seed S] [--out DIR] [-- quadhand-online options...]
# Writes DIR/seed<k>/{online.txt,online.csv,sim.csv} and prints one line per
# flight and a summary. Needs data/sdf/quadhand (scripts/quickstart.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
flights=10 first=1 out=out/moving_target_loopback
extra=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --flights) flights="$2"; shift 2 ;;
    --first-seed) first="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    *) echo "moving_target_loopback: unknown option $1 (--help)" >&2; exit 2 ;;
  esac
done
if [[ ! "$flights" =~ ^[1-9][0-9]*$ || ! "$first" =~ ^[0-9]+$ ]]; then
  echo "moving_target_loopback: --flights must be a positive integer and --first-seed a non-negative one" >&2
  exit 2
fi
if [[ ! -d data/sdf/quadhand ]]; then
  echo "moving_target_loopback: data/sdf/quadhand is missing: run bash scripts/quickstart.sh first" >&2
  exit 2
fi
for b in quadhand-sim quadhand-online quadhand-flightcheck; do
  [[ -x build/bin/$b ]] || bash scripts/build.sh quadhand-sim quadhand-online quadhand-flightcheck
done
task=data/tasks/conveyor_cup.yaml
port="${QUADHAND_ONLINE_PORT:-14570}"
mkdir -p "$out"
summary="$out/summary.tsv"
printf 'seed\tpass_s\texit\tleast_clearance_m\ttool_at_arrival_m\ttool_measured_m\treplan_median_ms\ttarget_replans\n' > "$summary"
for ((seed = first; seed < first + flights; ++seed)); do
  dir="$out/seed$seed"
  mkdir -p "$dir"
  pass=$(awk -v s="$seed" 'BEGIN { printf "%.1f", 11 + (s % 5) * 0.5 }')
  ./build/bin/quadhand-sim --udp "udp://127.0.0.1:$port" --realtime --start-task "$task" --seed "$seed" \
    --target-rate 30 --target-noise 0.005 --target-pass-time "$pass" --duration 60 --quiet --log "$dir/sim.csv" &
  sim=$!
  sleep 0.3
  set +e
  ./build/bin/quadhand-online "$task" --vehicle "udp://127.0.0.1:$port" --log "$dir/online.csv" --max-duration 40 \
    "${extra[@]}" > "$dir/online.txt" 2>&1
  code=$?
  set -e
  kill -TERM "$sim" 2>/dev/null || true
  wait "$sim" 2>/dev/null || true
  end=$(sed -n "s/.*ended at the vehicle's t = \([0-9.]*\) s.*/\1/p" "$dir/online.txt")
  arrival=$(sed -n "s/.*at the arrival (the vehicle's t = \([0-9.]*\) s).*/\1/p" "$dir/online.txt")
  measured=$(sed -n 's/.*tool to target (as measured): \([0-9.]*\) m at the arrival.*/\1/p' "$dir/online.txt")
  median=$(sed -n 's/.*latency median \([0-9.]*\) ms.*/\1/p' "$dir/online.txt")
  replans=$(sed -n 's/.* \([0-9]*\) replans for its prediction.*/\1/p' "$dir/online.txt")
  least=nan tool=nan
  if [[ -n "$end" && -s "$dir/sim.csv" ]]; then
    least=$( (./build/bin/quadhand-flightcheck "$task" "$dir/sim.csv" --until "$end" --json 2>/dev/null || true) |
      python3 -c 'import json,sys; print("%.4f" % json.load(sys.stdin)["min_clearance"])' 2>/dev/null || echo nan)
  fi
  if [[ -n "$arrival" && -s "$dir/sim.csv" ]]; then
    tool=$( (./build/bin/quadhand-flightcheck "$task" "$dir/sim.csv" --until "$arrival" --json 2>/dev/null || true) |
      python3 -c 'import json,sys; print("%.4f" % json.load(sys.stdin)["tool_error"])' 2>/dev/null || echo nan)
  fi
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$seed" "$pass" "$code" "$least" "$tool" "${measured:-nan}" \
    "${median:-nan}" "${replans:-0}" >> "$summary"
  echo "seed $seed (cup passes at $pass s): exit $code, least clearance $least m (truth), tool $tool m from the cup" \
    "at the arrival (truth; ${measured:-?} m as measured), replans median ${median:-?} ms"
done
python3 - "$summary" <<'EOF'
import csv, math, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1]), delimiter="\t"))
num = lambda r, k: float(r[k]) if r[k] not in ("", "nan") else math.nan
tools = [num(r, "tool_at_arrival_m") for r in rows]
least = [num(r, "least_clearance_m") for r in rows]
medians = [num(r, "replan_median_ms") for r in rows if not math.isnan(num(r, "replan_median_ms"))]
within = sum(1 for t in tools if t <= 0.01)
kept = sum(1 for c in least if c >= 0.028)
print(f"{len(rows)} flights: tool within 1 cm of the cup at the arrival (truth) in {within}; "
      f"clearance >= safety - 2 mm (0.028 m, truth) in {kept}; exit 0 in {sum(1 for r in rows if r['exit'] == '0')}")
if medians:
    print(f"replan latency: median of the flights' medians {statistics.median(medians):.1f} ms")
EOF

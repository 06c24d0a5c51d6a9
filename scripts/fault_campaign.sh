#!/usr/bin/env bash
# Flights under faults (docs/reliability.md, "Flights over a faulty link"):
# quadhand-sim --udp --realtime as the vehicle, quadhand-linkproxy between it
# and quadhand-online, the default task. Every flight is judged twice: by
# quadhand-online's own exit code, and independently by quadhand-flightcheck
# on the simulator's record (the vehicle's true states) against the exact
# meshes. Prints one row per flight and exits 1 when any flight went into
# the scene, or when quadhand-online claimed a success (exit 0) that the
# simulator's record does not bear out.
#
#   scripts/fault_campaign.sh [--smoke] [--only NAME,...] [--seeds N] [--task FILE] [--build DIR] [--out DIR]
#                             [-- ONLINE_OPTIONS...]
#
# --smoke: one slow, lossy link and one jump of the estimate, one seed (the
# suite runs it). --only: the rows of those names (the first column of the
# table). --task: the task flown (default data/tasks/window_cup.yaml, whose
# link SDFs scripts/quickstart.sh makes). --build: where bin/ is (default
# build). Each row is a link fault (quadhand-linkproxy's options) and/or a
# simulator fault (the faults: key of docs/sim.md, written into a copy of
# data/sim/quadhand_sim.yaml); most kinds at two severities.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build
seeds=3
smoke=0
only=""
task=data/tasks/window_cup.yaml
out=out/fault_campaign
while [[ $# -gt 0 ]]; do
  case "$1" in
    --smoke) smoke=1; seeds=1; shift ;;
    --seeds) seeds="$2"; shift 2 ;;
    --only) only=",$2,"; shift 2 ;;
    --task) task="$2"; shift 2 ;;
    --build) build="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "fault_campaign: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
online_options=("$@")
if ! [[ "$seeds" =~ ^[1-9][0-9]*$ ]]; then echo "fault_campaign: --seeds must be a whole number >= 1" >&2; exit 2; fi
for program in quadhand-sim quadhand-online quadhand-linkproxy quadhand-flightcheck; do
  if [[ ! -x "$build/bin/$program" ]]; then
    echo "fault_campaign: $build/bin/$program is missing (bash scripts/build.sh $program)" >&2
    exit 2
  fi
done
if [[ ! -r "$task" ]]; then echo "fault_campaign: cannot read the task $task" >&2; exit 2; fi
if [[ "$task" == data/tasks/window_cup.yaml && ! -d data/sdf/quadhand ]]; then
  echo "fault_campaign: data/sdf/quadhand is missing: run bash scripts/quickstart.sh first" >&2
  exit 2
fi
mkdir -p "$out"

# name | quadhand-linkproxy options (both directions; "@kill=S": no link fault, quadhand-online killed
#        with SIGKILL S seconds after it starts) | simulator faults (YAML flow map, docs/sim.md)
matrix=(
  "calm||"
  "loss20_delay50|--loss 0.2 --delay 0.05 --jitter 0.02|"
  "loss10_delay100|--loss 0.1 --delay 0.1 --jitter 0.03|"
  "burst10_delay150|--loss 0.1 --burst 5 --delay 0.15 --jitter 0.05|"
  "dup5_corrupt2|--duplicate 0.05 --corrupt 0.02 --delay 0.02 --jitter 0.01|"
  "outage1.5s|--outage 5,1.5|"
  "wind1||{wind: {steady: [1, 0.5, 0]}}"
  "wind3||{wind: {steady: [-3, 1, 0]}}"
  "gust1||{wind: {steady: [1, 0, 0], gust_intensity: 1}}"
  "gust2.5||{wind: {steady: [-1, 1, 0], gust_intensity: 2.5}}"
  "motor0.9||{motor: {rotor: 0, thrust_factor: 0.9}}"
  "motor0.75||{motor: {rotor: 2, thrust_factor: 0.75}}"
  "servo_lag0.05||{servo: {extra_lag: 0.05}}"
  "servo_lag0.2||{servo: {extra_lag: 0.2}}"
  "jump1cm||{estimate: {jump: {time: 3, offset: [0.01, 0, 0]}}}"
  "jump2cm||{estimate: {jump: {time: 3, offset: [0, 0.014, -0.014]}}}"
  "drift2mm/s||{estimate: {drift: [0.002, 0.0, 0]}}"
  "freeze0.3s||{estimate: {freeze: {time: 3, duration: 0.3}}}"
  "nan0.2s||{estimate: {nan: {time: 3, duration: 0.2}}}"
  "freeze1.5s||{estimate: {freeze: {time: 4, duration: 1.5}}}"
  "planner_killed|@kill=5|"
)
if [[ $smoke -eq 1 ]]; then
  matrix=("burst10_delay150|--loss 0.1 --burst 5 --delay 0.15 --jitter 0.05|"
          "jump2cm||{estimate: {jump: {time: 3, offset: [0, 0.014, -0.014]}}}")
fi

free_port() { python3 -c 'import socket; s=socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }

printf '%-18s %4s %5s  %-34s %9s %9s %8s %s\n' fault seed exit "quadhand-online said" "flown min" "tool err" "rate Hz" verdict
failures=0
for row in "${matrix[@]}"; do
  IFS='|' read -r name proxy_text sim_faults <<<"$row"
  if [[ -n "$only" && "$only" != *",$name,"* ]]; then continue; fi
  kill_after=""
  if [[ "$proxy_text" == @kill=* ]]; then kill_after="${proxy_text#@kill=}"; proxy_text=""; fi
  read -r -a proxy_options <<<"$proxy_text"
  for ((seed = 1; seed <= seeds; ++seed)); do
    base="$out/${name//\//_}_seed$seed"
    sim_port=$(free_port); proxy_port=$(free_port)
    # The simulator's configuration: the bundled one, its robot made
    # absolute, and the row's faults.
    sed "s|^robot: .*|robot: $PWD/meshes/quadhand/quadhand.urdf|" data/sim/quadhand_sim.yaml >"$base.sim.yaml"
    if [[ -n "$sim_faults" ]]; then echo "faults: $sim_faults" >>"$base.sim.yaml"; fi
    "$build/bin/quadhand-sim" --udp "udp://127.0.0.1:$sim_port" --realtime --start-task "$task" --duration 120 \
      --config "$base.sim.yaml" --seed "$seed" --quiet --log "$base.sim.csv" 2>"$base.sim.err" &
    sim=$!
    "$build/bin/quadhand-linkproxy" --listen "udp://127.0.0.1:$proxy_port" --vehicle "udp://127.0.0.1:$sim_port" \
      --seed "$seed" "${proxy_options[@]}" 2>"$base.proxy.txt" &
    proxy=$!
    sleep 0.3
    set +e
    if [[ -n "$kill_after" ]]; then
      # The planner dies mid-flight: the autopilot's offboard-loss failsafe
      # must hold the vehicle; it is judged on the simulator's record, which
      # runs on for 5 s after the kill.
      "$build/bin/quadhand-online" "$task" --vehicle "udp://127.0.0.1:$proxy_port" --max-duration 100 \
        --log "$base.online.csv" "${online_options[@]}" >"$base.online.txt" 2>&1 &
      online=$!
      sleep "$kill_after"
      kill -KILL "$online" 2>/dev/null
      { wait "$online"; } 2>/dev/null
      code=$?
      echo "KILLED by SIGKILL at $kill_after s" >>"$base.online.txt"
      sleep 5
    else
      "$build/bin/quadhand-online" "$task" --vehicle "udp://127.0.0.1:$proxy_port" --max-duration 100 \
        --log "$base.online.csv" "${online_options[@]}" >"$base.online.txt" 2>&1
      code=$?
    fi
    set -e
    kill -TERM "$proxy" "$sim" 2>/dev/null || true
    wait "$proxy" "$sim" 2>/dev/null || true
    said=$(grep -m1 -E '^(arrived|VEHICLE LOST|REFUSED|PLANNING FAILED|INTERRUPTED|CLEARANCE|ABORTED|KILLED)' "$base.online.txt" |
      sed 's/ after .*//' || true)
    rate=$(grep -o -m1 'setpoints at [0-9.]* Hz' "$base.online.txt" | grep -o '[0-9.]*' || echo "-")
    if [[ ! -s "$base.sim.csv" ]]; then
      echo "fault_campaign: $name seed $seed: the simulator wrote no record ($base.sim.err)" >&2
      failures=$((failures + 1))
      continue
    fi
    set +e
    check=$("$build/bin/quadhand-flightcheck" "$task" "$base.sim.csv" --json 2>"$base.check.err")
    check_code=$?
    set -e
    if [[ $check_code -ne 0 && $check_code -ne 6 ]]; then
      echo "fault_campaign: quadhand-flightcheck failed on $base.sim.csv: $(cat "$base.check.err")" >&2
      failures=$((failures + 1))
      continue
    fi
    clearance=$(sed -E 's/.*"min_clearance": ([-0-9.e]+).*/\1/' <<<"$check")
    tool=$(sed -E 's/.*"tool_error": ([-0-9.e]+).*/\1/' <<<"$check")
    verdict="ok"
    if awk -v c="$clearance" 'BEGIN { exit !(c < 0) }'; then
      verdict="COLLISION"
      failures=$((failures + 1))
    elif [[ $code -eq 0 && $check_code -ne 0 ]]; then
      verdict="DISHONEST (exit 0, clearance lost)"
      failures=$((failures + 1))
    elif [[ $code -eq 0 ]] && awk -v e="$tool" 'BEGIN { exit !(e > 0.01) }'; then
      verdict="completed, tool > 1 cm off"
    elif [[ $code -eq 0 ]]; then
      verdict="completed"
    elif [[ $code -eq 6 && "$said" == "CLEARANCE NOT VERIFIED"* ]]; then
      verdict="not verified, reported"
    elif [[ $code -eq 6 ]]; then
      verdict="clearance lost, reported"
    else
      verdict="aborted"
    fi
    printf '%-18s %4d %5d  %-34s %8.4fm %8.4fm %8s %s\n' "$name" "$seed" "$code" "${said:-?}" "$clearance" "$tool" \
      "$rate" "$verdict"
  done
done
if [[ $failures -gt 0 ]]; then
  echo "fault_campaign: $failures flight(s) failed the campaign (records in $out)" >&2
  exit 1
fi
echo "fault_campaign: every flight kept out of the scene, and every exit 0 was borne out (records in $out)"

#!/usr/bin/env bash
# Flights under faults (docs/reliability.md, "Flights under faults"):
# quadhand-sim --udp --realtime as the vehicle, quadhand-linkproxy between it
# and quadhand-online, the default task. Every flight is judged twice: by
# quadhand-online's own exit code, and independently by quadhand-flightcheck
# on the simulator's record (the vehicle's true states) against the exact
# meshes. Prints one row per flight, then a summary per fault and severity
# and the targets, and exits 1 when any flight went into the scene, or when
# quadhand-online claimed a success (exit 0) that the simulator's record
# does not bear out.
#
#   scripts/fault_campaign.sh [--smoke] [--only KIND[:SEVERITY],...] [--seeds N] [--jobs N] [--task FILE]
#                             [--build DIR] [--out DIR] [--summary] [-- ONLINE_OPTIONS...]
#
# --smoke: one slow, lossy link and one 2 cm jump of the estimate, one seed
# (the suite runs it). --only: the rows of those kinds, or of one severity
# of a kind (the first two columns of the table, e.g. jump:2cm). --seeds:
# flights per row (default 3). --jobs: flights at a time (default 2; the
# planner-killed and CPU-load rows always fly alone). --task: the task flown
# (default data/tasks/window_cup.yaml, whose link SDFs scripts/quickstart.sh
# makes; a mission, e.g. data/tasks/missions/gap_crossing_grasp.yaml, is
# judged with its held object, docs/reliability.md). --build: where bin/ is
# (default build). --out: where the records go. --summary: fly nothing,
# print the table of the records already in --out.
# Each row is a link fault (quadhand-linkproxy's options, or its YAML for
# one-way faults) and/or a simulator fault (the faults: key of docs/sim.md,
# written into a copy of data/sim/quadhand_sim.yaml), at three severities.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build
seeds=3
jobs=2
smoke=0
summary_only=0
only=""
task=data/tasks/window_cup.yaml
out=out/fault_campaign
while [[ $# -gt 0 ]]; do
  case "$1" in
    --smoke) smoke=1; seeds=1; shift ;;
    --summary) summary_only=1; shift ;;
    --seeds) seeds="$2"; shift 2 ;;
    --jobs) jobs="$2"; shift 2 ;;
    --only) only=",$2,"; shift 2 ;;
    --task) task="$2"; shift 2 ;;
    --build) build="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,27p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "fault_campaign: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
online_options=("$@")
if ! [[ "$seeds" =~ ^[1-9][0-9]*$ ]]; then echo "fault_campaign: --seeds must be a whole number >= 1" >&2; exit 2; fi
if ! [[ "$jobs" =~ ^[1-9][0-9]*$ ]]; then echo "fault_campaign: --jobs must be a whole number >= 1" >&2; exit 2; fi
for program in quadhand-sim quadhand-online quadhand-linkproxy quadhand-flightcheck; do
  if [[ ! -x "$build/bin/$program" ]]; then
    echo "fault_campaign: $build/bin/$program is missing (bash scripts/build.sh $program)" >&2
    exit 2
  fi
done
if ! command -v python3 >/dev/null; then echo "fault_campaign: python3 is missing (apt install python3)" >&2; exit 2; fi
if [[ ! -r "$task" ]]; then echo "fault_campaign: cannot read the task $task" >&2; exit 2; fi
if [[ "$task" == data/tasks/window_cup.yaml && ! -d data/sdf/quadhand ]]; then
  echo "fault_campaign: data/sdf/quadhand is missing: run bash scripts/quickstart.sh first" >&2
  exit 2
fi
mkdir -p "$out"
if [[ $summary_only -eq 0 ]]; then rm -f "$out"/*.result; fi
# A mission's flight: the payload rows make its grasped object heavier or
# lighter than declared, and its record has no single goal (tool error -).
mission=0
if grep -q '^mission:' "$task"; then mission=1; fi

# kind | severity | class | link | simulator
#   class: mild (the issue's mild faults: the task must complete), severe
#     (must end in a safe state), beyond (past the mild bounds) or other.
#   link: quadhand-linkproxy options (both directions); "yaml:MAP" a
#     fault file for it (one-way faults: up = to the vehicle, down = from
#     it); "@kill=S" no link fault, quadhand-online killed (SIGKILL) S s
#     after it starts; "@load=N" no link fault, N busy processes on the
#     machine for the whole flight.
#   simulator: the faults: map of docs/sim.md; "@payload=F" a payload at the
#     tool of F times the 150 g the controller is told (a mission: its
#     grasped objects weigh F times their declared mass).
matrix=(
  "calm|none|mild||"
  "loss|5%|mild|--loss 0.05 --delay 0.02 --jitter 0.01|"
  "loss|10%|mild|--loss 0.1 --delay 0.02 --jitter 0.01|"
  "loss|20%|mild|--loss 0.2 --delay 0.02 --jitter 0.01|"
  "burst|5%x5_50ms|mild|--loss 0.05 --burst 5 --delay 0.05 --jitter 0.02|"
  "burst|10%x5_100ms|mild|--loss 0.1 --burst 5 --delay 0.1 --jitter 0.03|"
  "burst|10%x5_150ms|beyond|--loss 0.1 --burst 5 --delay 0.15 --jitter 0.05|"
  "latency|50ms|mild|--delay 0.05 --jitter 0.01 --fifo|"
  "latency|100ms|mild|--delay 0.1 --jitter 0.02 --fifo|"
  "latency|200ms|beyond|--delay 0.2 --jitter 0.03 --fifo|"
  "reorder|20+-20ms|mild|--delay 0.02 --jitter 0.02|"
  "reorder|50+-50ms|mild|--delay 0.05 --jitter 0.05|"
  "reorder|100+-100ms|beyond|--delay 0.1 --jitter 0.1|"
  "duplicate|5%|other|--duplicate 0.05 --delay 0.02 --jitter 0.01|"
  "duplicate|20%|other|--duplicate 0.2 --delay 0.02 --jitter 0.01|"
  "duplicate|50%|other|--duplicate 0.5 --delay 0.02 --jitter 0.01|"
  "corrupt|1%|other|--corrupt 0.01 --delay 0.02 --jitter 0.01|"
  "corrupt|5%|other|--corrupt 0.05 --delay 0.02 --jitter 0.01|"
  "corrupt|10%|other|--corrupt 0.1 --delay 0.02 --jitter 0.01|"
  "outage|0.5s|other|--outage 5,0.5|"
  "outage|1.5s|severe|--outage 5,1.5|"
  "outage|3s|severe|--outage 5,3|"
  "uplink_outage|0.5s|other|yaml:{up: {outages: [{start: 5, length: 0.5}]}}|"
  "uplink_outage|1.5s|severe|yaml:{up: {outages: [{start: 5, length: 1.5}]}}|"
  "uplink_outage|3s|severe|yaml:{up: {outages: [{start: 5, length: 3}]}}|"
  "downlink_outage|0.5s|other|yaml:{down: {outages: [{start: 5, length: 0.5}]}}|"
  "downlink_outage|1.5s|severe|yaml:{down: {outages: [{start: 5, length: 1.5}]}}|"
  "downlink_outage|3s|severe|yaml:{down: {outages: [{start: 5, length: 3}]}}|"
  "uplink_loss|10%x3|mild|yaml:{up: {loss: 0.1, burst: 3}}|"
  "uplink_loss|30%x3|beyond|yaml:{up: {loss: 0.3, burst: 3}}|"
  "uplink_loss|50%x3|beyond|yaml:{up: {loss: 0.5, burst: 3}}|"
  "downlink_delay|100ms|mild|yaml:{down: {delay: 0.1, jitter: 0.02, fifo: true}}|"
  "downlink_delay|200ms|beyond|yaml:{down: {delay: 0.2, jitter: 0.03, fifo: true}}|"
  "downlink_delay|300ms|beyond|yaml:{down: {delay: 0.3, jitter: 0.05, fifo: true}}|"
  "wind|1m/s|mild||{wind: {steady: [1, 0.5, 0]}}"
  "wind|2m/s|mild||{wind: {steady: [0, -2, 0]}}"
  "wind|3m/s|mild||{wind: {steady: [-3, 1, 0]}}"
  "gust|1+0.5|mild||{wind: {steady: [1, 0, 0], gust_intensity: 0.5}}"
  "gust|1+1|mild||{wind: {steady: [1, 0, 0], gust_intensity: 1}}"
  "gust|1.4+2.5|beyond||{wind: {steady: [-1, 1, 0], gust_intensity: 2.5}}"
  "motor|90%|other||{motor: {rotor: 0, thrust_factor: 0.9}}"
  "motor|80%|other||{motor: {rotor: 1, thrust_factor: 0.8}}"
  "motor|75%|other||{motor: {rotor: 2, thrust_factor: 0.75}}"
  "servo_lag|+0.05s|other||{servo: {extra_lag: 0.05}}"
  "servo_lag|+0.1s|other||{servo: {extra_lag: 0.1}}"
  "servo_lag|+0.2s|other||{servo: {extra_lag: 0.2}}"
  "servo_stall|j2@6s|other||{servo: {stall_joint: 1, stall_time: 6}}"
  "servo_stall|j2@4s|other||{servo: {stall_joint: 1, stall_time: 4}}"
  "servo_stall|j2@2s|other||{servo: {stall_joint: 1, stall_time: 2}}"
  "payload|-30%|mild||@payload=0.7"
  "payload|+30%|mild||@payload=1.3"
  "payload|+45%|beyond||@payload=1.45"
  "jump|1cm|mild||{estimate: {jump: {time: 3, offset: [0.01, 0, 0]}}}"
  "jump|2cm|mild||{estimate: {jump: {time: 3, offset: [0, 0.014, -0.014]}}}"
  "jump|5cm|beyond||{estimate: {jump: {time: 3, offset: [0, -0.05, 0]}}}"
  "drift|1mm/s|other||{estimate: {drift: [0.001, 0, 0]}}"
  "drift|2mm/s|other||{estimate: {drift: [0.002, 0, 0]}}"
  "drift|5mm/s|other||{estimate: {drift: [0, 0.0035, -0.0035]}}"
  "freeze|0.3s|severe||{estimate: {freeze: {time: 3, duration: 0.3}}}"
  "freeze|1s|severe||{estimate: {freeze: {time: 4, duration: 1}}}"
  "freeze|1.5s|severe||{estimate: {freeze: {time: 4, duration: 1.5}}}"
  "nan|0.1s|other||{estimate: {nan: {time: 3, duration: 0.1}}}"
  "nan|0.5s|other||{estimate: {nan: {time: 3, duration: 0.5}}}"
  "nan|1s|other||{estimate: {nan: {time: 3, duration: 1}}}"
  "killed|@3s|severe|@kill=3|"
  "killed|@5s|severe|@kill=5|"
  "killed|@7s|severe|@kill=7|"
  "cpu_load|2procs|other|@load=2|"
  "cpu_load|4procs|other|@load=4|"
  "cpu_load|8procs|other|@load=8|"
)
if [[ $smoke -eq 1 ]]; then
  matrix=("burst|10%x5_150ms|beyond|--loss 0.1 --burst 5 --delay 0.15 --jitter 0.05|"
          "jump|2cm|mild||{estimate: {jump: {time: 3, offset: [0, 0.014, -0.014]}}}")
fi

free_port() { python3 -c 'import socket; s=socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }

# One flight: writes $base.result (one tab-separated line, or a line
# starting with "ERROR" naming what could not run).
fly() {
  local kind="$1" severity="$2" class="$3" link="$4" sim_faults="$5" seed="$6" base="$7"
  local kill_after="" load=0 proxy_options=() sim_port proxy_port sim proxy online code loaders=()
  if [[ "$link" == @kill=* ]]; then kill_after="${link#@kill=}"; link=""; fi
  if [[ "$link" == @load=* ]]; then load="${link#@load=}"; link=""; fi
  if [[ "$link" == yaml:* ]]; then
    echo "${link#yaml:}" >"$base.proxy.yaml"
    proxy_options=(--faults "$base.proxy.yaml")
  else
    read -r -a proxy_options <<<"$link"
  fi
  sim_port=$(free_port); proxy_port=$(free_port)
  # The simulator's configuration: the bundled one, its robot made
  # absolute, and the row's faults.
  sed "s|^robot: .*|robot: $PWD/meshes/quadhand/quadhand.urdf|" data/sim/quadhand_sim.yaml >"$base.sim.yaml"
  local sim_options=()
  if [[ "$sim_faults" == @payload=* && $mission -eq 1 ]]; then
    # A mission's grasped object weighs F times its declared mass.
    echo "faults: {payload_mass_factor: ${sim_faults#@payload=}}" >>"$base.sim.yaml"
  elif [[ "$sim_faults" == @payload=* ]]; then
    # The controller is told the vehicle (1.70 kg) and a 150 g payload; the
    # tool carries F times that.
    local factor="${sim_faults#@payload=}"
    sed -i "s|^  mass: 0  .*|  mass: 1.85|" "$base.sim.yaml"
    sim_options=(--payload "$(python3 -c "print(0.15 * $factor)")")
  elif [[ -n "$sim_faults" ]]; then
    echo "faults: $sim_faults" >>"$base.sim.yaml"
  fi
  for ((k = 0; k < load; ++k)); do
    (trap 'exit 0' TERM; while :; do :; done) &
    loaders+=($!)
  done
  "$build/bin/quadhand-sim" --udp "udp://127.0.0.1:$sim_port" --realtime --start-task "$task" --duration 120 \
    --config "$base.sim.yaml" --seed "$seed" --quiet --log "$base.sim.csv" "${sim_options[@]}" 2>"$base.sim.err" &
  sim=$!
  "$build/bin/quadhand-linkproxy" --listen "udp://127.0.0.1:$proxy_port" --vehicle "udp://127.0.0.1:$sim_port" \
    --seed "$seed" "${proxy_options[@]}" 2>"$base.proxy.txt" &
  proxy=$!
  sleep 0.3
  if ! kill -0 "$sim" 2>/dev/null || ! kill -0 "$proxy" 2>/dev/null; then
    kill -TERM "$sim" "$proxy" "${loaders[@]}" 2>/dev/null || true
    wait "$sim" "$proxy" "${loaders[@]}" 2>/dev/null || true
    echo "ERROR quadhand-sim or quadhand-linkproxy did not start: $(cat "$base.sim.err" "$base.proxy.txt" | head -2)" \
      >"$base.result"
    return
  fi
  set +e
  if [[ -n "$kill_after" ]]; then
    # The planner dies mid-flight: the autopilot's offboard-loss failsafe
    # must hold the vehicle; it is judged on the simulator's record, which
    # runs on for 8 s after the kill.
    "$build/bin/quadhand-online" "$task" --vehicle "udp://127.0.0.1:$proxy_port" --max-duration 100 \
      --log "$base.online.csv" "${online_options[@]}" >"$base.online.txt" 2>&1 &
    online=$!
    sleep "$kill_after"
    kill -KILL "$online" 2>/dev/null
    { wait "$online"; } 2>/dev/null
    code=$?
    echo "KILLED by SIGKILL at $kill_after s" >>"$base.online.txt"
    sleep 8
  else
    "$build/bin/quadhand-online" "$task" --vehicle "udp://127.0.0.1:$proxy_port" --max-duration 100 \
      --log "$base.online.csv" "${online_options[@]}" >"$base.online.txt" 2>&1
    code=$?
    # A flight that did not complete is judged where it was left: 5 s more
    # of the simulator's record (the autopilot's failsafe, after an online
    # mode that gave up).
    if [[ $code -ne 0 ]]; then sleep 5; fi
  fi
  set -e
  kill -TERM "$proxy" "$sim" "${loaders[@]}" 2>/dev/null || true
  wait "$proxy" "$sim" "${loaders[@]}" 2>/dev/null || true
  local said rate check check_code clearance tool rest verdict
  said=$(grep -m1 -E '^(arrived|VEHICLE LOST|REFUSED|PLANNING FAILED|HOLDING|INTERRUPTED|CLEARANCE|ABORTED|KILLED)' "$base.online.txt" |
    sed 's/ after .*//' || true)
  rate=$(grep -o -m1 'setpoints at [0-9.]* Hz' "$base.online.txt" | grep -o '[0-9.]*' || echo "-")
  if [[ ! -s "$base.sim.csv" ]]; then
    echo "ERROR the simulator wrote no record ($base.sim.err)" >"$base.result"
    return
  fi
  set +e
  check=$("$build/bin/quadhand-flightcheck" "$task" "$base.sim.csv" --json 2>"$base.check.err")
  check_code=$?
  set -e
  if [[ $check_code -ne 0 && $check_code -ne 6 ]]; then
    echo "ERROR quadhand-flightcheck failed on $base.sim.csv: $(cat "$base.check.err")" >"$base.result"
    return
  fi
  clearance=$(sed -E 's/.*"min_clearance": ([-0-9.e]+).*/\1/' <<<"$check")
  tool=$(sed -E 's/.*"tool_error": ([-0-9.e]+).*/\1/' <<<"$check")
  # A mission's held object counts as the robot does: the flown minimum is
  # the whole body's, object included.
  local object
  object=$(sed -nE 's/.*"held_object_min_clearance": ([-0-9.e]+).*/\1/p' <<<"$check")
  if [[ -n "$object" ]] && awk -v o="$object" -v c="$clearance" 'BEGIN { exit !(o < c) }'; then clearance="$object"; fi
  # At rest at the record's end (the last row's speed): where a flight that
  # did not complete was left.
  rest=$(tail -n 1 "$base.sim.csv" | awk -F, '{ printf "%.3f", sqrt($5 * $5 + $6 * $6 + $7 * $7) }')
  verdict="ok"
  if awk -v c="$clearance" 'BEGIN { exit !(c < 0) }'; then
    verdict="COLLISION"
  elif [[ $code -eq 0 && $check_code -ne 0 ]]; then
    verdict="DISHONEST (exit 0, clearance lost)"
  elif [[ $code -eq 0 ]] && awk -v e="$tool" 'BEGIN { exit !(e > 0.01) }'; then
    verdict="completed, tool > 1 cm off"
  elif [[ $code -eq 0 ]]; then
    verdict="completed"
  elif [[ -n "$kill_after" ]]; then
    verdict="killed; failsafe"
  elif [[ $code -eq 7 ]]; then
    verdict="aborted, stopped safely"
  elif [[ $code -eq 6 ]] && grep -q "aborting, " "$base.online.txt"; then
    verdict="aborted, clearance lost, reported"
  elif [[ $code -eq 6 && "$said" == "CLEARANCE NOT VERIFIED"* ]]; then
    verdict="not verified, reported"
  elif [[ $code -eq 6 ]]; then
    verdict="clearance lost, reported"
  else
    verdict="stopped"
  fi
  printf '%s\t%s\t%s\t%d\t%d\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$kind" "$severity" "$class" "$seed" "$code" \
    "${said:-?}" "$clearance" "$tool" "$rate" "$rest" "$check_code" "$verdict" >"$base.result"
}

start_time=$(date +%s)
declare -a bases=()
for row in "${matrix[@]}"; do
  IFS='|' read -r kind severity class link sim_faults <<<"$row"
  if [[ -n "$only" && "$only" != *",$kind,"* && "$only" != *",$kind:$severity,"* ]]; then continue; fi
  exclusive=0
  if [[ "$link" == @kill=* || "$link" == @load=* ]]; then exclusive=1; fi
  for ((seed = 1; seed <= seeds; ++seed)); do
    name="${kind}_${severity}"
    base="$out/${name//[^A-Za-z0-9_.+-]/_}_seed$seed"
    bases+=("$base")
    if [[ $summary_only -eq 1 ]]; then
      continue
    elif [[ $exclusive -eq 1 ]]; then
      wait
      fly "$kind" "$severity" "$class" "$link" "$sim_faults" "$seed" "$base"
    else
      while [[ $(jobs -rp | wc -l) -ge $jobs ]]; do wait -n || true; done
      fly "$kind" "$severity" "$class" "$link" "$sim_faults" "$seed" "$base" &
    fi
  done
done
wait
elapsed=$(($(date +%s) - start_time))
if [[ $summary_only -eq 1 ]]; then elapsed=-1; fi

results=()
for base in "${bases[@]}"; do
  if [[ ! -s "$base.result" ]]; then echo "ERROR no result for $base" >"$base.result"; fi
  results+=("$base.result")
done
set +e
python3 - "$elapsed" "$jobs" "${results[@]}" <<'EOF'
import sys
elapsed, jobs, paths = int(sys.argv[1]), sys.argv[2], sys.argv[3:]
rows, errors = [], []
for path in paths:
    line = open(path).read().rstrip("\n")
    if line.startswith("ERROR"):
        errors.append(f"{path}: {line[6:]}")
        continue
    f = line.split("\t")
    # Aborted: the online mode's own reaction began (a retreat along the
    # plan on the insertion, a stalled joint's brake), whatever the exit.
    try:
        aborted = "aborting, " in open(path[:-len(".result")] + ".online.txt", errors="replace").read()
    except OSError:
        aborted = False
    rows.append(dict(kind=f[0], severity=f[1], cls=f[2], seed=int(f[3]), code=int(f[4]), said=f[5],
                     clearance=float(f[6]), tool=float(f[7]), rate=None if f[8] == "-" else float(f[8]),
                     rest=float(f[9]), check=int(f[10]), verdict=f[11], aborted=aborted or int(f[4]) == 7))
def tool_text(tool):
    return "-" if tool < 0 else f"{tool:.4f}m"  # a mission has no single goal
print(f"{'fault':<15}{'severity':<14}{'seed':>4}{'exit':>5}  {'quadhand-online said':<26}{'flown min':>10}"
      f"{'tool err':>10}{'rate Hz':>8}  verdict")
for r in rows:
    rate = "-" if r["rate"] is None else f"{r['rate']:.2f}"
    print(f"{r['kind']:<15}{r['severity']:<14}{r['seed']:>4}{r['code']:>5}  {r['said'][:25]:<26}"
          f"{r['clearance']:>9.4f}m{tool_text(r['tool']):>10}{rate:>8}  {r['verdict']}")
# Per fault and severity.
print()
print(f"{'fault':<15}{'severity':<14}{'class':<8}{'flights':>8}{'completed':>10}{'safe end':>9}"
      f"{'flown min':>11}{'tool err':>18}{'min rate':>9}  exits")
groups = {}
for r in rows:
    groups.setdefault((r["kind"], r["severity"]), []).append(r)
def completed(r):
    return r["code"] == 0 and r["check"] == 0 and r["tool"] <= 0.01
def safe_end(r):
    # Not completed, out of the scene, and at rest when the record ends (a
    # hold: the online mode's or the autopilot's failsafe).
    return not completed(r) and r["clearance"] >= 0 and r["rest"] < 0.1
for (kind, severity), g in groups.items():
    rates = [r["rate"] for r in g if r["rate"] is not None]
    print(f"{kind:<15}{severity:<14}{g[0]['cls']:<8}{len(g):>8}{sum(map(completed, g)):>10}{sum(map(safe_end, g)):>9}"
          f"{min(r['clearance'] for r in g) * 100:>9.2f}cm"
          + (f"{'-':>18}" if min(r['tool'] for r in g) < 0 else
             f"{min(r['tool'] for r in g) * 1000:>14.1f}-{max(r['tool'] for r in g) * 1000:.1f}mm")
          + f"{(min(rates) if rates else float('nan')):>9.2f}  {','.join(str(r['code']) for r in g)}")
collisions = [r for r in rows if r["clearance"] < 0]
dishonest = [r for r in rows if r["code"] == 0 and r["check"] != 0]
mild = [r for r in rows if r["cls"] == "mild"]
severe = [r for r in rows if r["cls"] == "severe"]
# The issue's target: >= the safety distance less 2 mm for every flight
# that is not aborted (an aborted one: >= 0, the collisions above).
low = [r for r in rows if r["check"] != 0 and not r["aborted"] and r["clearance"] >= 0]
low_aborted = [r for r in rows if r["check"] != 0 and r["aborted"] and r["clearance"] >= 0]
loaded = [r["rate"] for r in rows if r["kind"] == "cpu_load" and r["rate"] is not None]
kinds = {r["kind"] for r in rows if r["kind"] != "calm"}
print()
print(f"{len(rows)} flights, {len(kinds)} fault kinds, {len(groups)} rows, "
      + (f"in {elapsed // 60} min {elapsed % 60} s ({jobs} at a time; the killed and CPU-load rows alone)"
         if elapsed >= 0 else "from the records of earlier runs"))
print(f"collisions (flown clearance < 0): {len(collisions)}")
print(f"exit 0 not borne out by the record: {len(dishonest)}")
print(f"below the safety distance less 2 mm, not aborted (reported, exit 6): {len(low)}"
      + ("" if not low else " (" + ", ".join(sorted({r['kind'] + ':' + r['severity'] for r in low})) + ")"))
print(f"below the safety distance less 2 mm after an abort began (out of the scene): {len(low_aborted)}"
      + ("" if not low_aborted else
         " (" + ", ".join(sorted({r['kind'] + ':' + r['severity'] for r in low_aborted})) + ")"))
if mild:
    done = sum(map(completed, mild))
    print(f"mild faults completed with the tool within 1 cm: {done}/{len(mild)} ({100.0 * done / len(mild):.1f} %)"
          + ("" if done == len(mild) else "; not: " + ", ".join(sorted({r['kind'] + ':' + r['severity']
                                                                      for r in mild if not completed(r)}))))
if severe:
    safe = sum(1 for r in severe if completed(r) or safe_end(r))
    print(f"severe faults ending completed or at rest out of the scene: {safe}/{len(severe)}")
if loaded:
    print(f"setpoint stream under CPU load: at least {min(loaded):.2f} Hz")
for e in errors:
    print(f"ERROR {e}")
sys.exit(1 if collisions or dishonest or errors else 0)
EOF
status=$?
set -e
if [[ $status -ne 0 ]]; then
  echo "fault_campaign: some flights failed the campaign or could not run (records in $out)" >&2
  exit 1
fi
echo "fault_campaign: every flight kept out of the scene, and every exit 0 was borne out (records in $out)"

#!/usr/bin/env bash
# The MAVLink abuse test (docs/reliability.md): quadhand-sim --udp as the
# vehicle and quadhand-online flying the default task to the cup over a
# signed loopback link (both --require-signing), while quadhand-mavlink-flood
# sends each of them RATE frames/s (default 100000) of garbage, unsigned
# frames from a foreign system, frames signed with a wrong key and replays of
# frames signed with the right key, for SECONDS (default 10) from the start
# of the flight. Checks: the flight arrives (exit 0), the setpoint stream
# keeps at least 45 Hz, neither side accepts more frames than its real peer
# sent (nothing forged or replayed got in), and the hostile frames show up
# in the drop counters. Prints the figures; exit 0 when every check holds.
#   scripts/mavlink_flood.sh [BUILD_DIR] [SECONDS] [RATE]
# Needs data/sdf/quadhand (scripts/quickstart.sh). Writes out/flood_*.
set -euo pipefail
cd "$(dirname "$0")/.."
build="build"
if [[ $# -gt 0 && -d "$1" ]]; then build="$1"; shift; fi
seconds="${1:-10}"
rate="${2:-100000}"
for tool in quadhand-sim quadhand-online quadhand-mavlink-flood; do
  if [[ ! -x "$build/bin/$tool" ]]; then
    echo "mavlink_flood: $build/bin/$tool is missing (bash scripts/build.sh $tool)" >&2
    exit 2
  fi
done
if [[ ! -d data/sdf/quadhand ]]; then
  echo "mavlink_flood: data/sdf/quadhand is missing: run bash scripts/quickstart.sh first" >&2
  exit 2
fi
sim_port="${QUADHAND_FLOOD_SIM_PORT:-14620}"
online_port="${QUADHAND_FLOOD_ONLINE_PORT:-14621}"
mkdir -p out
key="out/flood_signing.key"
head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$key"

"./$build/bin/quadhand-sim" --udp "udp://127.0.0.1:$sim_port" --realtime --start-task data/tasks/window_cup.yaml \
  --duration 90 --signing-key "$key" --require-signing --system-id 1 2> out/flood_sim.err &
sim=$!
trap 'kill -TERM "$sim" "${online:-}" "${flood:-}" 2>/dev/null || true' EXIT
sleep 0.3
"./$build/bin/quadhand-online" data/tasks/window_cup.yaml --vehicle "udp://127.0.0.1:$sim_port" \
  --bind "udp://127.0.0.1:$online_port" --signing-key "$key" --require-signing --max-duration 80 \
  --log out/flood_flight.csv > out/flood_online.out 2>&1 &
online=$!
# The flood starts as the planning ends and the handshake begins.
sleep 1
"./$build/bin/quadhand-mavlink-flood" --target "udp://127.0.0.1:$sim_port,1,191" \
  --target "udp://127.0.0.1:$online_port,1,1" --key "$key" --rate "$rate" --seconds "$seconds" \
  --replay-age 0.5 > out/flood.out &
flood=$!
set +e
wait "$online"
online_code=$?
wait "$flood"
kill -TERM "$sim" 2>/dev/null
wait "$sim"
set -e
trap - EXIT

cat out/flood.out
grep -E "arrived|setpoints at|link:|replans|flown path|INTERRUPTED|LOST|FAILED|REFUSED" out/flood_online.out || true
tail -1 out/flood_sim.err
# The first number after a pattern in a file.
number() { grep -oE "$1" "$2" | head -1 | grep -oE '[0-9]+(\.[0-9]+)?' | tail -1; }
hz=$(grep -oE '[0-9.]+ Hz \(target' out/flood_online.out | grep -oE '^[0-9.]+' || echo 0)
online_accepted=$(number 'link: [0-9]+ frames accepted' out/flood_online.out)
online_sent=$(number 'ignored\), [0-9]+ sent' out/flood_online.out)
sim_accepted=$(number 'frames received [0-9]+' out/flood_sim.err)
sim_sent=$(number ', sent [0-9]+' out/flood_sim.err)
flooded=$(awk '{s += $3} END {print s + 0}' out/flood.out)
failed=0
check() {  # check DESCRIPTION CONDITION...
  local what="$1"; shift
  if "$@"; then echo "ok      $what"; else echo "FAILED  $what"; failed=1; fi
}
check "quadhand-online arrived (exit $online_code)" test "$online_code" -eq 0
check "setpoint rate $hz Hz >= 45" awk -v hz="$hz" 'BEGIN { exit !(hz >= 45) }'
check "quadhand-online accepted $online_accepted frames <= the $sim_sent the simulator sent" \
  test "${online_accepted:-1}" -le "${sim_sent:-0}"
check "quadhand-sim accepted $sim_accepted frames <= the $online_sent quadhand-online sent" \
  test "${sim_accepted:-1}" -le "${online_sent:-0}"
check "flood of $flooded frames sent in ${seconds} s" test "${flooded:-0}" -gt 0
exit "$failed"

#!/usr/bin/env bash
# The online mode on loopback (docs/online.md): quadhand-sim --udp as the
# vehicle, in real time, and quadhand-online flying the default task to the
# cup. Extra arguments go to quadhand-online (e.g. --replan-threshold 0.03).
#   scripts/online_loopback.sh [BUILD_DIR] [quadhand-online options...]
# Needs the link SDFs (data/sdf/quadhand, made by scripts/quickstart.sh);
# builds quadhand-sim and quadhand-online into build/ when they are missing.
# Writes out/online_flight.csv (quadhand-online --log) and
# out/online_sim_flown.csv (the simulator's own 50 Hz record).
set -euo pipefail
cd "$(dirname "$0")/.."
build="build"
if [[ $# -gt 0 && -d "$1" ]]; then build="$1"; shift; fi
port="${QUADHAND_ONLINE_PORT:-14540}"
if [[ ! -x "$build/bin/quadhand-sim" || ! -x "$build/bin/quadhand-online" ]]; then
  if [[ "$build" != "build" ]]; then
    echo "online_loopback: $build/bin lacks quadhand-sim or quadhand-online" >&2
    exit 2
  fi
  bash scripts/build.sh quadhand-sim quadhand-online
fi
if [[ ! -d data/sdf/quadhand ]]; then
  echo "online_loopback: data/sdf/quadhand is missing: run bash scripts/quickstart.sh first" >&2
  exit 2
fi
mkdir -p out
"./$build/bin/quadhand-sim" --udp "udp://127.0.0.1:$port" --realtime --start-task data/tasks/window_cup.yaml \
  --duration 60 --quiet --log out/online_sim_flown.csv &
sim=$!
trap 'kill -TERM "$sim" 2>/dev/null || true; wait "$sim" 2>/dev/null || true' EXIT
sleep 0.3
set +e
"./$build/bin/quadhand-online" data/tasks/window_cup.yaml --vehicle "udp://127.0.0.1:$port" \
  --log out/online_flight.csv "$@"
code=$?
set -e
echo "quadhand-online exit code: $code"
exit "$code"

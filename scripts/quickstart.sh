#!/usr/bin/env bash
# The README's first command: install what is needed, build, and run the main
# job on the bundled default: generate the reference robot's link SDFs, then
# plan the window-and-cup task (data/tasks/window_cup.yaml).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh quadhand-sdfgen quadhand-plan quadhand-bench quadhand_python_core
echo
echo "== Generating the link SDFs of the reference robot (about half a minute)"
./build/bin/quadhand-sdfgen --urdf meshes/quadhand/quadhand.urdf --out data/sdf/quadhand
echo
echo "== Planning the default task: through two windows to the cup"
mkdir -p out
./build/bin/quadhand-plan data/tasks/window_cup.yaml \
  --out out/window_cup.csv --report out/window_cup.json --html out/window_cup.html
echo
echo "Plan (CSV):   out/window_cup.csv"
echo "Report:       out/window_cup.json"
echo "3-D page:     out/window_cup.html (open it in a browser; it works offline)"
echo "From Python:  PYTHONPATH=build/python python3 examples/python/plan_window_cup.py (docs/python.md)"

#!/usr/bin/env bash
# The README's first command: install what is needed, build, and run the main
# job on the bundled default (the reference robot's link SDFs).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh quadhand-sdfgen quadhand-meshgen
echo
echo "== Generating the link SDFs of the reference robot"
./build/bin/quadhand-sdfgen --urdf meshes/quadhand/quadhand.urdf --out data/sdf/quadhand
echo
echo "Link SDFs are in data/sdf/quadhand/ (inspect one: build/bin/quadhand-sdfgen info data/sdf/quadhand/link3.qhsdf)"

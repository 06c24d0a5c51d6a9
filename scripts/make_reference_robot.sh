#!/usr/bin/env bash
# Regenerates the reference robot of robot.md into meshes/quadhand: one closed
# binary STL per collision link, quadhand.urdf and primitives.yaml. The outputs
# are committed; run this only after changing apps/meshgen (then re-run the
# geometry and robot tests, and regenerate the link SDFs).
# Usage: bash scripts/make_reference_robot.sh [extra quadhand-meshgen options]
# Environment: BUILD_DIR (default: build).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${BUILD_DIR:-build}
if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release > "$build_dir.configure.log" 2>&1 ||
    { cat "$build_dir.configure.log" >&2; exit 1; }
fi
cmake --build "$build_dir" --target quadhand-meshgen -j "$(nproc 2>/dev/null || echo 2)"
"$build_dir/bin/quadhand-meshgen" --out meshes/quadhand "$@"

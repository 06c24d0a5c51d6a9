#!/usr/bin/env bash
# Configures (Release) and builds into build/, executables in build/bin.
# Usage: bash scripts/build.sh [target ...]    (no target: everything, tests included)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > build.configure.log 2>&1 ||
  { cat build.configure.log >&2; exit 1; }
if [ $# -gt 0 ]; then
  cmake --build build -j "$jobs" --target "$@"
else
  cmake --build build -j "$jobs"
fi

#!/usr/bin/env bash
# The fault campaign's smoke matrix (scripts/fault_campaign.sh --smoke) as a
# test: the default task with link SDFs of its own (coarse, made here, so
# that a fresh clone needs no quickstart first), both flights judged on the
# simulator's record. Fails on any collision or unfounded exit 0.
#   fault_campaign_smoke.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
source_dir="$1"
build_dir="$2"
work=$(mktemp -d "${TMPDIR:-/tmp}/quadhand_fault_smoke.XXXXXX")
trap 'rm -rf "$work"' EXIT
"$build_dir/bin/quadhand-sdfgen" -q --urdf "$source_dir/meshes/quadhand/quadhand.urdf" --out "$work/sdf" \
  --resolution 0.005 --padding 0.05
sed -e "s|^robot: .*|robot: $source_dir/meshes/quadhand/quadhand.urdf|" \
    -e "s|^sdf_dir: .*|sdf_dir: $work/sdf|" \
    -e "s|^scene: .*|scene: $source_dir/data/scenes/window_cup.pcd|" \
    "$source_dir/data/tasks/window_cup.yaml" >"$work/task.yaml"
bash "$source_dir/scripts/fault_campaign.sh" --smoke --task "$work/task.yaml" --build "$build_dir" --out "$work/out"

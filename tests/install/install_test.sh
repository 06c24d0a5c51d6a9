#!/usr/bin/env bash
# Installs the build into a temporary prefix, then builds and runs
# examples/cpp against the installed tree alone (find_package(quadhand)), plans
# with the installed programs, robot and data, and imports the installed
# Python module. Run by ctest: install_test.sh SOURCE_DIR BUILD_DIR PYTHON.
set -euo pipefail
source_dir=$1
build_dir=$2
python=$3
work=$(mktemp -d "${TMPDIR:-/tmp}/quadhand-install-test.XXXXXX")
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix

step() { echo "== $*"; }
fail() { echo "install_test: FAILED: $*" >&2; exit 1; }

step "cmake --install into $prefix"
cmake --install "$build_dir" --prefix "$prefix" >"$work/install.log" || { cat "$work/install.log"; fail "cmake --install"; }
config=$prefix/lib/cmake/quadhand/quadhandConfig.cmake
[ -f "$config" ] || config=$(find "$prefix" -name quadhandConfig.cmake | head -n 1)
[ -f "$config" ] || fail "no quadhandConfig.cmake installed"
# The installed package must not point back into the source or build tree.
if grep -rlF -e "$source_dir/" -e "$build_dir/" "$(dirname "$config")"; then
  fail "the installed CMake package names the source or build tree"
fi
[ -f "$prefix/include/quadhand/planner/planner.h" ] || fail "public headers not installed"
data=$prefix/share/quadhand
[ -f "$data/meshes/quadhand/quadhand.urdf" ] || fail "reference robot not installed"
[ -f "$data/data/tasks/window_cup.yaml" ] && [ -f "$data/data/scenes/window_cup.pcd" ] || fail "default data not installed"

step "building examples/cpp against the installed tree"
cmake -S "$source_dir/examples/cpp" -B "$work/example" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release \
  >"$work/configure.log" 2>&1 || { cat "$work/configure.log"; fail "configuring examples/cpp"; }
grep -q "quadhand_DIR:PATH=$(dirname "$config")" "$work/example/CMakeCache.txt" ||
  fail "examples/cpp did not find the installed package"
cmake --build "$work/example" -j 2 >"$work/build.log" 2>&1 || { tail -n 40 "$work/build.log"; fail "building examples/cpp"; }

step "link SDFs with the installed quadhand-sdfgen"
"$prefix/bin/quadhand-sdfgen" -q --urdf "$data/meshes/quadhand/quadhand.urdf" --out "$work/sdf" \
  --resolution 0.005 --padding 0.05 >/dev/null || fail "installed quadhand-sdfgen"
sed -e "s#^sdf_dir:.*#sdf_dir: $work/sdf#" "$data/data/tasks/window_cup.yaml" >"$data/data/tasks/window_cup_test.yaml"

step "planning the installed default task with the example"
status=0
"$work/example/plan_task" "$data/data/tasks/window_cup_test.yaml" >"$work/report.json" || status=$?
[ "$status" -eq 0 ] || { cat "$work/report.json"; fail "plan_task exited $status"; }
grep -q '"success": true' "$work/report.json" || fail "the example's plan did not succeed"
"$prefix/bin/quadhand-plan" --help >/dev/null || fail "installed quadhand-plan --help"

step "importing the installed Python module"
site=$prefix/lib/python3/dist-packages
PYTHONPATH=$site "$python" -c "
import sys, quadhand
assert quadhand.__file__.startswith('$site'), quadhand.__file__
robot = quadhand.Robot('$data/meshes/quadhand/quadhand.urdf', sdf_dir='$work/sdf')
result = quadhand.plan('$data/data/tasks/window_cup_test.yaml', robot=robot)
assert result.success, result.message
print('python', quadhand.__version__, result.status)
" || fail "the installed Python module"
echo "install_test: passed"

#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz/, clang with AddressSanitizer and
# UndefinedBehaviorSanitizer) into build-fuzz/ and runs each for SECONDS
# (default 60), starting from the committed seed corpora
# (tests/fuzz/corpus/<target>/, never written to: the growing corpora live in
# build-fuzz/corpus/). A crash, leak-free abort, timeout (10 s per input) or
# sanitizer report is kept in build-fuzz/crashes/<target>/ and fails the run.
# Prints executions, coverage and findings per target. Not part of CI.
#
# Usage: bash scripts/fuzz.sh [SECONDS] [TARGET...]
#   targets: point_cloud mesh urdf task planner_config bench_config sim_config sdf mavlink sensor_stream ros_bag
# Needs clang (Debian: clang-14, libclang-rt-14-dev holds libFuzzer).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
[[ $# -gt 0 ]] && shift
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || (( seconds < 1 )); then
  echo "fuzz.sh: SECONDS must be a positive whole number (got '$seconds')" >&2
  exit 2
fi
all=(point_cloud mesh urdf task planner_config bench_config sim_config sdf mavlink sensor_stream ros_bag)
targets=("$@")
[[ ${#targets[@]} -eq 0 ]] && targets=("${all[@]}")
for t in "${targets[@]}"; do
  [[ " ${all[*]} " == *" $t "* ]] || { echo "fuzz.sh: unknown target '$t' (${all[*]})" >&2; exit 2; }
done
cc=$(command -v clang || command -v clang-14 || true)
cxx=$(command -v clang++ || command -v clang++-14 || true)
if [[ -z "$cc" || -z "$cxx" ]]; then
  echo "fuzz.sh: clang is missing (apt-get install clang-14 libclang-rt-14-dev)" >&2
  exit 2
fi
jobs=$(nproc 2>/dev/null || echo 2)
flags="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -O1 -g"
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER="$cc" -DCMAKE_CXX_COMPILER="$cxx" \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_INTERPROCEDURAL_OPTIMIZATION=OFF -DQUADHAND_BUILD_PYTHON=OFF -DQUADHAND_BUILD_TESTS=OFF \
  -DQUADHAND_BUILD_BENCHMARKS=OFF -DQUADHAND_BUILD_FUZZERS=ON > build-fuzz.configure.log 2>&1 ||
  { cat build-fuzz.configure.log >&2; exit 1; }
cmake --build build-fuzz -j "$jobs" --target $(printf 'fuzz_%s ' "${targets[@]}")
export ASAN_OPTIONS="detect_leaks=0:alloc_dealloc_mismatch=0:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
failed=0
printf '%-16s %12s %10s %8s %s\n' target executions exec/s coverage result
for t in "${targets[@]}"; do
  corpus="build-fuzz/corpus/$t"
  crashes="build-fuzz/crashes/$t"
  mkdir -p "$corpus" "$crashes"
  log="build-fuzz/fuzz_$t.log"
  set +e
  "build-fuzz/bin/fuzz_$t" "$corpus" "tests/fuzz/corpus/$t" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -max_len=65536 -artifact_prefix="$crashes/" -print_final_stats=1 > "$log" 2>&1
  code=$?
  set -e
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*$')
  result="ok"
  if [[ $code -ne 0 ]]; then
    result="FOUND (exit $code): $(ls "$crashes" | head -3 | tr '\n' ' ')see $log"
    failed=1
  fi
  printf '%-16s %12s %10s %8s %s\n' "$t" "${runs:-?}" "${rate:-?}" "${cov:-?}" "$result"
done
exit "$failed"

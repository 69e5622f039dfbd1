#!/usr/bin/env bash
# Soak (issue 9): builds hostile_test (Release) in build-soak and runs its disabled Soak test: 10 000 frames
# of tests/soak/soak.json (repeated tearing while a hand waves the sheet), checking for non-finite values
# every frame and the mesh invariants (docs/architecture.md) after every remesh, printing per-1000-frame frame
# time, triangle count and memory (current RSS, getrusage peak RSS). Keeps the report in
# bench/results/soak-<date>.txt.  (SOAK_FRAMES, SOAK_SCENARIO, SOAK_THREADS, SOAK_BUILD, JOBS overridable)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
dir=${SOAK_BUILD:-build-soak}
test -f "$dir/build.ninja" || cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DPAPERTEAR_BUILD_TESTS=ON -DPAPERTEAR_BUILD_APPS=OFF -DPAPERTEAR_BUILD_BENCH=OFF
cmake --build "$dir" -j "${JOBS:-2}" --target hostile_test
mkdir -p bench/results
report="bench/results/soak-$(date +%Y-%m-%d).txt"
export SOAK_REPORT="$root/$report"
"$dir/bin/hostile_test" --gtest_also_run_disabled_tests --gtest_filter='Soak.*'
echo "soak report: $report"

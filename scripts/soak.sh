#!/usr/bin/env bash
# Soak (issue 9): builds papertear-soak (tools/soak.cpp, Release) in build-soak and runs it: 10 000 frames
# of tests/soak/soak.json (repeated tearing while a hand waves the sheet), checking for non-finite values
# every frame and the mesh invariants (docs/architecture.md) after every remesh, printing per-1000-frame frame
# time, triangle count and memory (current RSS, getrusage peak RSS). Keeps the report in
# bench/results/soak-<date>.txt. SOAK_FRAMES, SOAK_SCENARIO and SOAK_THREADS become the tool's --frames,
# --scenario and --threads; SOAK_BUILD and JOBS are the build directory and its jobs.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
dir=${SOAK_BUILD:-build-soak}
test -f "$dir/build.ninja" || cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DPAPERTEAR_BUILD_TESTS=OFF -DPAPERTEAR_BUILD_APPS=OFF -DPAPERTEAR_BUILD_BENCH=OFF -DPAPERTEAR_BUILD_TOOLS=ON
# A build directory configured before the tools existed gets them too.
cmake -S . -B "$dir" -DPAPERTEAR_BUILD_TOOLS=ON > /dev/null
cmake --build "$dir" -j "${JOBS:-2}" --target papertear-soak
mkdir -p bench/results
report="bench/results/soak-$(date +%Y-%m-%d).txt"
args=(--report "$root/$report")
[ -n "${SOAK_SCENARIO:-}" ] && args+=(--scenario "$SOAK_SCENARIO")
[ -n "${SOAK_FRAMES:-}" ] && args+=(--frames "$SOAK_FRAMES")
[ -n "${SOAK_THREADS:-}" ] && args+=(--threads "$SOAK_THREADS")
"$dir/bin/papertear-soak" "${args[@]}"
echo "soak report: $report"

#!/usr/bin/env bash
# Runs the Google Benchmark suite and keeps the result under bench/results/<date>.json.
set -euo pipefail
build=${1:-build}
# A second run on the same day does not overwrite the first: <date>-2.json, <date>-3.json, ...
out=${BENCH_OUT:-bench/results/$(date +%Y-%m-%d).json}
n=2
while [ -z "${BENCH_OUT:-}" ] && [ -e "$out" ]; do
  out=bench/results/$(date +%Y-%m-%d)-$n.json
  n=$((n + 1))
done
mkdir -p bench/results
"$build/bin/papertear_bench" --benchmark_out="$out" --benchmark_out_format=json \
  --benchmark_counters_tabular=true ${BENCH_FILTER:+--benchmark_filter="$BENCH_FILTER"}
echo "benchmark results: $out"

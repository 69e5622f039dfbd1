#!/usr/bin/env bash
# Runs the Google Benchmark suite and keeps the result under bench/results/<date>.json.
set -euo pipefail
build=${1:-build}
out=bench/results/$(date +%Y-%m-%d).json
mkdir -p bench/results
"$build/bin/papertear_bench" --benchmark_out="$out" --benchmark_out_format=json \
  --benchmark_counters_tabular=true ${BENCH_FILTER:+--benchmark_filter="$BENCH_FILTER"}
echo "benchmark results: $out"

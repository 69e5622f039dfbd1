#!/usr/bin/env bash
# libFuzzer (issue 9): builds tests/fuzz with Debian's clang in build-fuzz (libraries with
# -fsanitize=fuzzer-no-link,address,undefined, targets with -fsanitize=fuzzer,address,undefined) and runs each
# target for FUZZ_SECONDS on a copy of its committed seed corpus (tests/fuzz/corpus/<target>). New inputs go to
# build-fuzz/corpus/<target>; findings (crash-*, leak-*, timeout-*, oom-*) to build-fuzz/findings/<target>.
# Prints executions and findings per target; exit 1 when anything was found.
# fuzz_scenario takes inputs up to FUZZ_MAX_LEN (1 MiB), grown to it from the start (-len_control=0; by
# default 60 s stayed under the largest seed). The quadratic array parse of issue 27 took 0.77 s on 8 KiB of
# `{}` in this build, under -timeout=20, and over 20 s on 1 MiB or on the 120 KB seed bad-many_objects.json
# (a finding); the linear parse takes 0.87 s and 0.09 s. fuzz_remesher stays at 8 KiB: its bytes are cuts,
# and a million bytes of cuts is a legitimately long run, not a finding.
# Usage: scripts/fuzz.sh [target...]   (FUZZ_SECONDS, FUZZ_MAX_LEN, FUZZ_BUILD, JOBS overridable)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
dir=${FUZZ_BUILD:-build-fuzz}
seconds=${FUZZ_SECONDS:-60}
jobs=${JOBS:-2}
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_scenario fuzz_remesher)
cxx=$(command -v clang++ || command -v clang++-14)
cc=$(command -v clang || command -v clang-14)
flags="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
test -f "$dir/build.ninja" || cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_C_COMPILER="$cc" -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
  -DPAPERTEAR_BUILD_FUZZ=ON -DPAPERTEAR_BUILD_TESTS=OFF -DPAPERTEAR_BUILD_APPS=OFF -DPAPERTEAR_BUILD_BENCH=OFF
cmake --build "$dir" -j "$jobs" --target "${targets[@]}"

export ASAN_OPTIONS=${ASAN_OPTIONS:-"detect_leaks=1:abort_on_error=1"}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-"print_stacktrace=1:halt_on_error=1"}
status=0
summary=""
for t in "${targets[@]}"; do
  corpus="$dir/corpus/$t"
  findings="$dir/findings/$t"
  mkdir -p "$corpus" "$findings"
  cp -n tests/fuzz/corpus/"$t"/* "$corpus"/ 2>/dev/null || true
  dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  log="$dir/$t.log"
  length=(-max_len=8192)
  if [ "$t" = fuzz_scenario ]; then length=(-max_len="${FUZZ_MAX_LEN:-1048576}" -len_control=0); fi
  echo "== $t: ${seconds} s on $(ls "$corpus" | wc -l) inputs (log: $log)"
  set +e
  "$dir/bin/$t" "$corpus" "${dict[@]}" -max_total_time="$seconds" -timeout=20 -rss_limit_mb=4096 \
    "${length[@]}" -artifact_prefix="$findings/" -print_final_stats=1 >"$log" 2>&1
  rc=$?
  set -e
  execs=$(grep -m1 '^stat::number_of_executed_units' "$log" | awk '{print $2}')
  [ -n "$execs" ] || execs=$(grep -oE '#[0-9]+' "$log" | tail -1 | tr -d '#')
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1)
  found=$(ls "$findings" | wc -l)
  line="$t: ${execs:-?} executions in ${seconds} s, ${cov:-cov: ?}, corpus $(ls "$corpus" | wc -l), findings $found (exit $rc)"
  summary+="$line"$'\n'
  if [ "$rc" -ne 0 ] || [ "$found" -ne 0 ]; then
    status=1
    grep -E 'ERROR|fuzz_(scenario|remesher):|SUMMARY|Test unit written' "$log" | head -20 || true
  fi
done
echo "---- fuzz summary"
printf '%s' "$summary"
exit $status

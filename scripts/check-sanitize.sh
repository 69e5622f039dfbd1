#!/usr/bin/env bash
# Sanitizer builds (issue 9): an ASan+UBSan build that runs the whole ctest suite, then a TSan build that
# runs the threaded tests (frame graph inside a task arena, batches over sheets, thread-count determinism).
# Usage: scripts/check-sanitize.sh [asan|tsan|all]   (JOBS, ASAN_BUILD, TSAN_BUILD, TSAN_FILTER overridable)
set -euo pipefail
what=${1:-all}
jobs=${JOBS:-2}
asan_dir=${ASAN_BUILD:-build-asan}
tsan_dir=${TSAN_BUILD:-build-tsan}
# Threaded tests: scenarios (two pulls, 1 vs 2 threads), the CLI (run, batch, thread-independent hash),
# the hostile motions (threads 2) and the viewer replay (engine driven by recorded sessions).
tsan_filter=${TSAN_FILTER:-'^(Scenarios|Cli|Hostile)\.|viewer_replay'}
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"

common=(-G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPAPERTEAR_BUILD_BENCH=OFF -DPAPERTEAR_BUILD_TESTS=ON
        -DPAPERTEAR_BUILD_APPS=ON)

run_asan() {
  # -fno-sanitize=vptr: oneTBB 2021.8's graph_task::destruct_and_deallocate (flow graph, every frame) runs
  # ~graph_task() and then static_casts `this` to the derived task type; the vptr check reports the destroyed
  # object ("downcast ... invalid vptr", _flow_graph_impl.h:368) and, unrecoverable, aborts every test that
  # steps a Simulation. It is TBB header code, not ours; UBSan suppressions do not apply to aborting checks.
  local flags="-fsanitize=address,undefined -fno-sanitize=vptr -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
  cmake -S . -B "$asan_dir" "${common[@]}" \
    -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
    -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
    -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined"
  local t0=$(date +%s)
  cmake --build "$asan_dir" -j "$jobs"
  local t1=$(date +%s)
  # detect_leaks: Mesa/llvmpipe (viewer screenshot) keeps allocations alive at exit; those are suppressed.
  export ASAN_OPTIONS=${ASAN_OPTIONS:-"detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1"}
  export LSAN_OPTIONS=${LSAN_OPTIONS:-"suppressions=$root/scripts/sanitizers/lsan.supp:print_suppressions=0"}
  export UBSAN_OPTIONS=${UBSAN_OPTIONS:-"print_stacktrace=1:halt_on_error=1"}
  # The embedding tests link the installed (instrumented) static libraries into an uninstrumented consumer
  # and an uninstrumented python: packaging checks, run by `make test`, not memory checks. The viewer
  # screenshot under xvfb leaves 240 bytes from Mesa's llvmpipe driver, already unloaded at exit (frames
  # "<unknown module>", so no suppression can name them): measured 2026-11-22, not our allocations.
  (cd "$asan_dir" && ctest --output-on-failure -j "$jobs" --timeout 1800 ${ASAN_FILTER:+-R "$ASAN_FILTER"} \
     -E "${ASAN_EXCLUDE:-^embedding_|^viewer_screenshot\$}")
  local t2=$(date +%s)
  echo "check-sanitize: asan+ubsan build $((t1 - t0)) s, suite $((t2 - t1)) s"
}

run_tsan() {
  local flags="-fsanitize=thread -fno-omit-frame-pointer"
  cmake -S . -B "$tsan_dir" "${common[@]}" \
    -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
    -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=thread"
  local t0=$(date +%s)
  # Only what the threaded tests need (the unit tests of single systems are serial).
  local targets=(scenarios_test cli_test hostile_test)
  local t
  for t in papertear_cli viewer_replay_test; do
    cmake --build "$tsan_dir" --target help | grep -q "^$t:" && targets+=("$t")
  done
  cmake --build "$tsan_dir" -j "$jobs" --target "${targets[@]}"
  local t1=$(date +%s)
  export TSAN_OPTIONS=${TSAN_OPTIONS:-"halt_on_error=1:second_deadlock_stack=1:suppressions=$root/scripts/sanitizers/tsan.supp"}
  (cd "$tsan_dir" && ctest --output-on-failure -j "$jobs" --timeout 1800 -R "$tsan_filter")
  local t2=$(date +%s)
  echo "check-sanitize: tsan build $((t1 - t0)) s, threaded tests $((t2 - t1)) s"
}

case "$what" in
  asan) run_asan ;;
  tsan) run_tsan ;;
  all) run_asan; run_tsan ;;
  *) echo "usage: $0 [asan|tsan|all]" >&2; exit 2 ;;
esac

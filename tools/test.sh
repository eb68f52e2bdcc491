#!/usr/bin/env bash
# Every test: installs what is missing (Debian packages), builds the AVR images and the checked
# host tree (preset `checked`, build/checked, its own tree: core/ instrumented for line coverage,
# every host object built with AddressSanitizer + UndefinedBehaviorSanitizer; tools/demo.sh's
# build/host is neither used nor touched), runs all tests with ctest (host unit tests,
# firmware logic on the fake HAL, plant fidelity, model lab, HIL tests of the real images in
# simavr, the fuzz targets' deterministic replay), prints core/ line coverage, and ends with
# ctest's summary. Non-zero on any failure; a sanitizer finding aborts its test, which fails.
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
cd "$THRUSTCAL_ROOT"

ensure_packages
build_avr
print_firmware_sizes
build_checked

# Sanitizer findings fail the run: UBSan stops at the first one (-fno-sanitize-recover), ASan
# always does; both print a stack. Leak checking stays on. A 16 MB quarantine (ASan's default is
# 256 MB): a block freed within the last 16 MB of frees is still caught when used, and the tests
# take ~15 % less CPU, mostly page faults saved (docs/testing.md, "The ASan quarantine").
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:strict_string_checks=1:quarantine_size_mb=16}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"

say "running tests"
find build/checked -name '*.gcda' -delete 2>/dev/null || true
log=build/checked/ctest.log
realtime_log=build/checked/ctest-realtime.log
set +e
# Tests that drive a simulated board through a pseudo-terminal paced to the wall clock (label
# `realtime`) wait far more than they compute: they run beside the others instead of taking
# their slots (docs/testing.md, "Test run time").
ctest --test-dir build/checked -L realtime -j 3 --output-on-failure --timeout 900 > "$realtime_log" 2>&1 &
realtime_pid=$!
ctest --test-dir build/checked -LE realtime -j "$JOBS" --output-on-failure --timeout 900 2>&1 | tee "$log"
status=${PIPESTATUS[0]}
wait "$realtime_pid"
realtime_status=$?
say "the realtime tests (run alongside)"
cat "$realtime_log"
[ "$status" -eq 0 ] && status=$realtime_status
set -e

say "core/ line coverage"
cov_status=0
cov_out=$(gcovr -r "$THRUSTCAL_ROOT" --filter "$THRUSTCAL_ROOT/core/" \
  --print-summary --fail-under-line 90 -o build/checked/coverage.txt build/checked 2>&1) || cov_status=$?
echo "$cov_out" | grep -E '^(lines|branches):' || echo "$cov_out"
[ $cov_status -eq 0 ] || echo "error: core/ line coverage is below 90 % (details: build/checked/coverage.txt)"

echo
echo "ctest summary (realtime tests):"
sed -n '/tests passed, /,$p' "$realtime_log"
echo "ctest summary (all other tests):"
sed -n '/tests passed, /,$p' "$log"
say "tools/test.sh finished"
[ "$status" -eq 0 ] || exit "$status"
exit $cov_status

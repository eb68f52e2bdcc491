#!/usr/bin/env bash
# libFuzzer on the host parsers (tests/fuzz): builds the `fuzz` preset (clang, ASan + UBSan,
# one binary per target) and runs each target for SECONDS seconds (default 60) on 1 job,
# starting from the seed corpus fuzz_replay_tests writes. A crash stops with the input in
# build/fuzz/crashes/<target>/; copy it into tests/fuzz/regressions/<target>/ (the replay test
# then runs it on every build) and fix the parser.
#   tools/fuzz.sh [SECONDS] [TARGET...]     targets: intel_hex eeprom_image column_map
#                                           lab_expression lab_csv (default: all)
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
cd "$THRUSTCAL_ROOT"

seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(intel_hex eeprom_image column_map lab_expression lab_csv)

ensure_packages
ensure_packages "${THRUSTCAL_FUZZ_PACKAGES[@]}"
say "configuring the fuzz tree (build/fuzz, clang)"
cmake --preset fuzz >/dev/null
say "building the fuzz targets and the seed corpus writer"
cmake --build --preset fuzz -j "$JOBS" --target fuzz_replay_tests $(printf 'fuzz_%s ' "${targets[@]}")
# the replay test writes the seed corpus (and replays it once)
FUZZ_REPLAY_CASES=0 build/fuzz/tests/fuzz/fuzz_replay_tests >/dev/null

export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
status=0
for t in "${targets[@]}"; do
  corpus="build/fuzz/corpus/$t"
  crashes="build/fuzz/crashes/$t"
  mkdir -p "$corpus" "$crashes"
  cp -n "build/fuzz/tests/fuzz/corpus/$t/"* "$corpus/" 2>/dev/null || true
  [ -d "tests/fuzz/regressions/$t" ] && cp -n "tests/fuzz/regressions/$t/"* "$corpus/" 2>/dev/null || true
  say "fuzzing $t for ${seconds} s"
  if ! "build/fuzz/tests/fuzz/fuzz_$t" -max_total_time="$seconds" -print_final_stats=1 \
       -artifact_prefix="$crashes/" -max_len=8192 "$corpus" 2>&1 | tail -n 12; then
    echo "error: fuzz_$t found a crash: see $crashes/ (copy it into tests/fuzz/regressions/$t/)"
    status=1
  fi
done
exit $status

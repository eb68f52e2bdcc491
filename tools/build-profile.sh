#!/usr/bin/env bash
# Where the checked tree's build time goes: builds the checked tree (tools/test.sh's flags:
# ASan + UBSan, core/ coverage) from nothing into its own directory, timing every compile, and
# prints the build's wall and CPU time, the compiles' summed CPU time and the slowest translation
# units. Nothing else is touched (build/checked stays as it is).
#
#   tools/build-profile.sh [DIR] [TOP]     DIR default build/profile (emptied first), TOP 25
#
# Compare two changes by running it on each (the machine's speed moves by 20-30 % between runs
# here: run each twice). docs/testing.md, "Build time of the checked tree", has what it showed.
set -euo pipefail

if [ "${1:-}" = "--compile" ]; then  # the compiler launcher: time one compile, log it
  shift
  log=$THRUSTCAL_PROFILE_LOG
  out="?"
  prev=""
  for a in "$@"; do
    [ "$prev" = "-o" ] && out=$a
    prev=$a
  done
  t=$(mktemp)
  rc=0
  /usr/bin/time -f "%U %S %e" -o "$t" "$@" || rc=$?
  read -r user sys wall < "$t"
  rm -f "$t"
  echo "$user $sys $wall $out" >> "$log"
  exit $rc
fi

source "$(dirname "$0")/lib/common.sh"
cd "$THRUSTCAL_ROOT"
dir=$(realpath -m "${1:-build/profile}")
top=${2:-25}
case "$dir" in
  "$THRUSTCAL_ROOT"|"$THRUSTCAL_ROOT/build"|"$THRUSTCAL_ROOT/build/checked"|"$THRUSTCAL_ROOT/build/host")
    die "tools/build-profile.sh empties DIR first: give it a directory of its own, not $dir" ;;
esac
[ -x /usr/bin/time ] || ensure_packages time
ensure_packages

rm -rf "$dir"
mkdir -p "$dir"
export THRUSTCAL_PROFILE_LOG="$dir/compiles.txt"
: > "$THRUSTCAL_PROFILE_LOG"
self=$(realpath "$0")
say "configuring the checked tree in ${dir#"$THRUSTCAL_ROOT"/} with a timing compiler launcher"
cmake --preset checked -B "$dir" "${THRUSTCAL_CHECKED_FLAGS[@]}" \
  -DCMAKE_CXX_COMPILER_LAUNCHER="$self;--compile" -DCMAKE_C_COMPILER_LAUNCHER="$self;--compile" >/dev/null
say "building it with -j $JOBS (a few minutes)"
/usr/bin/time -f "%e %U %S" -o "$dir/build-time.txt" cmake --build "$dir" -j "$JOBS" > "$dir/build.log" 2>&1 \
  || { tail -20 "$dir/build.log"; die "the build failed (log: $dir/build.log)"; }
read -r wall user sys < "$dir/build-time.txt"

printf 'build: %.0f s wall, %.0f CPU s (%.0f user + %.0f sys), ' "$wall" "$(awk -v u="$user" -v s="$sys" 'BEGIN { print u + s }')" "$user" "$sys"
awk '{ sum += $1 + $2 } END { printf "%d compiles summing %.0f CPU s\n", NR, sum }' "$THRUSTCAL_PROFILE_LOG"
echo "(the rest of the CPU: linking, archiving, make, GoogleTest discovery)"
echo
printf '%8s %8s  %s\n' "CPU s" "wall s" "object (the slowest compiles)"
awk -v root="$dir/" '{ name = $4; sub(root, "", name); printf "%8.1f %8.1f  %s\n", $1 + $2, $3, name }' \
  "$THRUSTCAL_PROFILE_LOG" | sort -rn | awk -v n="$top" 'NR <= n'
echo
echo "every compile: $THRUSTCAL_PROFILE_LOG (user s, sys s, wall s, object)"

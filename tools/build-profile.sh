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

awk -v wall="$wall" -v user="$user" -v sys="$sys" -v top="$top" -v root="$dir/" '
  { cpu = $1 + $2; sum += cpu; n++; name = $4; sub(root, "", name); line[n] = sprintf("%8.1f %8.1f  %s", cpu, $3, name); key[n] = cpu }
  END {
    printf "build: %.0f s wall, %.0f CPU s (%.0f user + %.0f sys), %d compiles summing %.0f CPU s\n", wall, user + sys, user, sys, n, sum
    printf "(the rest of the CPU: linking, archiving, make, GoogleTest discovery)\n\n"
    printf "%8s %8s  %s\n", "CPU s", "wall s", "object (the slowest compiles)"
    for (k = 1; k <= top && k <= n; k++) {
      best = 0
      for (i = 1; i <= n; i++) if (!(i in done) && (best == 0 || key[i] > key[best])) best = i
      done[best] = 1
      print line[best]
    }
  }' "$THRUSTCAL_PROFILE_LOG"
echo
echo "every compile: $THRUSTCAL_PROFILE_LOG (user s, sys s, wall s, object)"

#!/bin/sh
# A program does not link a library: `links_without.sh BINARY PATTERN` fails when ldd lists a
# library matching PATTERN for BINARY (e.g. the lab's tests and simavr: the lab needs the HEX
# codec, tools/hex, not the simulator). Fails too when ldd cannot read BINARY, so a missing
# binary is never a pass.
set -u
[ $# -eq 2 ] || { echo "usage: $0 BINARY PATTERN" >&2; exit 2; }
libs=$(ldd "$1" 2>&1) || { echo "error: ldd cannot read $1: $libs"; exit 1; }
echo "$libs" | grep -q 'libc\.so' || { echo "error: ldd lists no libc for $1: $libs"; exit 1; }
if echo "$libs" | grep -q -- "$2"; then
  echo "error: $1 links $(echo "$libs" | grep -- "$2" | awk '{print $1}' | tr '\n' ' ')"
  echo "  it must not: see docs/architecture.md, \"Layers\""
  exit 1
fi
echo "$1 links no $2"

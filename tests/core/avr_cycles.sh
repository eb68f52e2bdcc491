#!/bin/sh
# Cycle counts of core/'s per-frame code on the ATmega2560, measured in simavr with Timer1
# (clk/1, or clk/64 for the long runs). Needs avr-g++ and the host tree's thrustcal, which runs
# the image in simavr; not part of ctest.
#   tests/core/avr_cycles.sh
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
avr-g++ -mmcu=atmega2560 -DF_CPU=16000000UL -Os -std=gnu++14 -fno-exceptions -fno-rtti \
  -fno-threadsafe-statics -ffunction-sections -fdata-sections -Wl,--gc-sections \
  -I"$root/core/include" "$here/avr_cycles/cycles.cpp" \
  "$root"/core/src/median_filter.cpp "$root"/core/src/force_pwm.cpp "$root"/core/src/force_curve.cpp \
  "$root"/core/src/curve_builder.cpp "$root"/core/src/eeprom_codec.cpp "$root"/core/src/crc16.cpp \
  "$root"/core/src/motor_calibration.cpp "$root"/core/src/plausibility.cpp -Wl,-u,vfprintf -lprintf_min -o "$out/cycles.elf"
# simavr's own runner prints nothing of UART0 here; thrustcal's does (build/host, tools/demo.sh).
thrustcal=${THRUSTCAL:-"$root/build/host/tools/thrustcal/thrustcal"}
[ -x "$thrustcal" ] || { echo "error: no $thrustcal: build the host tree first (tools/demo.sh), or set THRUSTCAL" >&2; exit 1; }
"$thrustcal" sim run --elf "$out/cycles.elf" --duration 5 | grep -a -e cycles -e check

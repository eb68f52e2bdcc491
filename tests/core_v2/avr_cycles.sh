#!/bin/sh
# Model v2 cycle counts on the ATmega2560, measured in simavr (libsimavr) on the real core/
# code with the simulator's cycle probe (tools/sim: sim/cycle_probe.hpp, the bench's too): the
# AVR program brackets each measured call with markers, the host timestamps them with the
# simulated cycle counter. The same scenario also runs
# on the host; its result bytes (fitted models, every pulse) must equal the AVR's: integer
# code, 16-bit int or 32-bit int, same answers. Needs avr-g++, g++ and libsimavr-dev; not
# part of ctest (cycle figures, plus that one comparison).
#   tests/core_v2/avr_cycles.sh
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
avr-g++ -mmcu=atmega2560 -DF_CPU=16000000UL -Os -std=gnu++14 -fno-exceptions -fno-rtti \
  -fno-threadsafe-statics -ffunction-sections -fdata-sections -Wl,--gc-sections \
  -I"$root/core/include" -I"$root/tools/sim/include" "$here/avr_cycles/v2_cycles.cpp" \
  "$root"/core/src/model_v2.cpp "$root"/core/src/model_v2_fit.cpp "$root"/core/src/model_v2_runtime.cpp "$root"/core/src/force_pwm.cpp "$root"/core/src/force_curve.cpp \
  "$root"/core/src/curve_builder.cpp "$root"/core/src/motor_calibration.cpp \
  "$root"/core/src/battery_monitor.cpp "$root"/core/src/record_v2.cpp "$root"/core/src/crc16.cpp \
  "$root"/core/src/plausibility.cpp \
  -o "$out/v2_cycles.elf"
g++ -O2 -std=c++17 $(pkg-config --cflags simavr) -I"$root/tools/sim/include" \
  "$here/avr_cycles/run_cycles.cpp" "$root/tools/sim/src/cycle_probe.cpp" \
  $(pkg-config --libs simavr) -lelf -o "$out/run_cycles"
g++ -O2 -std=c++17 -I"$root/core/include" "$here/avr_cycles/scenario_host.cpp" \
  "$root"/core/src/model_v2.cpp "$root"/core/src/model_v2_fit.cpp "$root"/core/src/model_v2_runtime.cpp "$root"/core/src/force_pwm.cpp "$root"/core/src/force_curve.cpp \
  "$root"/core/src/curve_builder.cpp "$root"/core/src/motor_calibration.cpp \
  "$root"/core/src/battery_monitor.cpp "$root"/core/src/record_v2.cpp "$root"/core/src/crc16.cpp \
  "$root"/core/src/plausibility.cpp \
  -o "$out/scenario_host"
"$out/run_cycles" "$out/v2_cycles.elf" "$out/avr.hex"
"$out/scenario_host" > "$out/host.hex"
if cmp -s "$out/avr.hex" "$out/host.hex"; then
  echo "AVR and host results identical: $(($(tr -d '\n' < "$out/avr.hex" | wc -c) / 2)) bytes (models, filter, every pulse and flag)"
else
  echo "AVR and host results DIFFER (first differing lines below)"
  diff "$out/avr.hex" "$out/host.hex" | head -6
  exit 1
fi
if command -v avr-objdump >/dev/null; then
  if avr-objdump -d "$out/v2_cycles.elf" | grep -q -e '__addsf3' -e '__mulsf3' -e '__divsf3'; then
    echo "float routines linked into the benchmark image"; exit 1
  fi
  echo "no float routines in the image (checked with avr-objdump)"
fi

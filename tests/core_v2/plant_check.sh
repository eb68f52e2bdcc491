#!/bin/sh
# Model v2 vs thesis option 2.1 on the virtual bench's plant (tools/plant), steady state, four
# varied actuators: a preview of the bench's accuracy table with core/'s real code. Figures,
# not assertions; not part of ctest.   tests/core_v2/plant_check.sh
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
g++ -O2 -std=c++20 -I"$root/core/include" -I"$root/tools/plant/include" \
  "$here/plant_check/plant_check.cpp" \
  "$root"/tools/plant/src/actuator.cpp "$root"/tools/plant/src/params.cpp "$root"/tools/plant/src/random.cpp \
  "$root"/core/src/model_v2.cpp "$root"/core/src/model_v2_fit.cpp "$root"/core/src/model_v2_runtime.cpp \
  "$root"/core/src/force_pwm.cpp "$root"/core/src/force_curve.cpp \
  "$root"/core/src/curve_builder.cpp "$root"/core/src/motor_calibration.cpp "$root"/core/src/battery_monitor.cpp \
  -o "$out/plant_check"
"$out/plant_check"

#!/usr/bin/env bash
# The main job: installs what is missing, builds the firmware images and the host tool (nothing
# else: no test is built), then
# runs the virtual bench with the REAL firmware images in simavr:
#   1. calibrates four varied simulated KV1100 + APC 9x4.7 motors with gather_store
#      (curve 1 on a full 3S LiPo, curve 2 on a 10 V bench supply), EEPROM saved as Intel HEX;
#   2. flies the thesis's tethered lift-off with read_run: calibrated (each motor its own
#      record) and uncalibrated (the same PWM on all four);
#   2b. calibrates the same motors again with gather_store's `store v2` (model v2 fitted on the
#      board: force in effective motor voltage) and flies the lift-off on those records;
#   3. runs the model lab on the sweeps it just logged: thesis model vs the measurements, then
#      `lab walk` on the thesis's bench (one motor, LiPo and current-limited supply): the
#      diagnosis's advice followed step by step until the error is at the noise floor;
#   4. the swap experiment reduced (issue 19): motor 1 replaced by three parts, only slot 1
#      calibrated again, fly's 10-degree steps in every mode; a table and one plot overlaid;
#   5. each motor's dynamics (issue 26): gather_store's dyn on a stock motor and the KV900 part,
#      every measured time constant beside the plant's own.
# Results: build/demo/summary.json, build/demo/*.png, build/demo/lab/report.md, logs.
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
cd "$THRUSTCAL_ROOT"

# Only what the demo runs: the three images it flies and the thrustcal tool, in the plain tree
# (build/host; no tests, no instrumentation: tools/test.sh builds those in build/checked).
ensure_packages "${THRUSTCAL_DEMO_PACKAGES[@]}"
build_avr gather_store read_run fly
build_plain thrustcal
say "firmware images (avr-size)"
print_firmware_sizes

OUT="$THRUSTCAL_ROOT/build/demo"
TC="$THRUSTCAL_ROOT/build/host/tools/thrustcal/thrustcal"
SEEDS=(11 12 13 14)   # four varied motors (part-to-part spread 3 %)
rm -rf "$OUT"
mkdir -p "$OUT/logs" "$OUT/liftoff"
t0=$(date +%s)

say "1/4 calibrating four simulated motors with gather_store (curve 1: LiPo, curve 2: 10 V supply)"
"$TC" sim gather --seeds "${SEEDS[@]}" --slots 0 1 2 3 \
  --eeprom "$OUT/eeprom.hex" --log-dir "$OUT/logs" --json "$OUT/gather.json" 2> >(sed -u 's/^/   /' >&2)

say "2/4 tethered lift-off with read_run, calibrated and uncalibrated"
# Typed into the simulated UART (--via in-process): through the pty, `thrustcal board liftoff`'s
# client keeps read_run's 500 ms link alive by the wall clock, so the board may run no faster
# than real time while a motor spins (docs/sim.md); ctest's realtime tests fly that path.
"$TC" sim liftoff --eeprom "$OUT/eeprom.hex" --seeds "${SEEDS[@]}" --force 300 --mode both --via in-process \
  --out-dir "$OUT/liftoff" --json "$OUT/liftoff.json" 2> >(sed -u 's/^/   /' >&2)

say "2b/4 the same motors with model v2 (store v2 after each sweep), lift-off on v2 records"
"$TC" sim gather --seeds "${SEEDS[@]}" --slots 0 1 2 3 --model v2 \
  --eeprom "$OUT/eeprom_v2.hex" --json "$OUT/gather_v2.json" 2> >(sed -u 's/^/   /' >&2)
"$TC" sim liftoff --eeprom "$OUT/eeprom_v2.hex" --seeds "${SEEDS[@]}" --force 300 --mode calibrated \
  --via in-process --label v2 --out-dir "$OUT/liftoff" --json "$OUT/liftoff_v2.json" 2> >(sed -u 's/^/   /' >&2)

say "3/4 plots"
for k in 0 1 2 3; do
  [ -f "$OUT/logs/gather_slot${k}_curves.csv" ] || die "missing $OUT/logs/gather_slot${k}_curves.csv"
done
gnuplot <<GP
set datafile separator ","
set datafile commentschars "#"
set terminal pngcairo size 1400,1000 font ",11"
set output "$OUT/force_curves.png"
set multiplot layout 2,2 title "Stored force curves (EEPROM) vs the plant's true curve, per motor"
do for [k=0:3] {
  set title sprintf("motor %d", k)
  set xlabel "force [g]"; set ylabel "PWM [us]"; set key left top; set grid
  f = sprintf("$OUT/logs/gather_slot%d_curves.csv", k)
  plot f using 1:2 every ::1 with lines lw 2 title "curve 1 (LiPo)", \
       f using 1:4 every ::1 with lines dt 2 lc rgb "black" title "true at curve 1", \
       f using 1:3 every ::1 with lines lw 2 title "curve 2 (10 V supply)", \
       f using 1:5 every ::1 with lines dt 3 lc rgb "black" title "true at curve 2"
}
unset multiplot
set terminal pngcairo size 1400,1300 font ",11"
set output "$OUT/liftoff_thrust.png"
set multiplot layout 3,1 title "Tethered lift-off, 300 g per motor: thrust of each motor over time"
do for [mode in "calibrated v2 uncalibrated"] {
  set title (mode eq "calibrated" ? "calibrated, thesis model (option 2.1)" : (mode eq "v2" ? "calibrated, model v2" : "uncalibrated (same PWM on all four)"))
  set xlabel "t [s]"; set ylabel "thrust [g]"; set key right bottom; set grid
  f = sprintf("$OUT/liftoff/liftoff_%s.csv", mode)
  plot for [m=0:3] f using 1:(column(2+m)) every ::1 with lines lw 2 title sprintf("motor %d", m), \
       300 with lines dt 2 lc rgb "black" title "command"
}
unset multiplot
GP

say "4/4 model lab on the logged sweeps: the thesis model, then the diagnosis's advice followed to the noise floor"
mapfile -t SWEEPS < <(ls "$OUT"/logs/gather_slot*_curve[12].csv)
"$TC" lab diagnose "${SWEEPS[@]}" --model thesis | tee "$OUT/lab_diagnose.txt"
"$TC" lab diagnose "${SWEEPS[@]}" --model thesis --json > "$OUT/lab_diagnose.json"
# The thesis's bench: one motor, curve 1 on the LiPo, curve 2 on the current-limited 10 V supply.
# `lab walk` diagnoses, drops the rows it says do not measure the force (--where), adds the
# effect it advises when that earns its parameters, and again, until the verdict is "at the
# noise floor" or nothing earns; then prints the ladder it walked and writes the report.
BENCH=("$OUT"/logs/gather_slot0_curve1.csv "$OUT"/logs/gather_slot0_curve2.csv)
"$TC" lab walk "${BENCH[@]}" --model curve --report "$OUT/lab" | tee "$OUT/lab_walk.txt"
"$TC" lab walk "${BENCH[@]}" --model curve --json > "$OUT/lab_walk.json"
# the same walk on all four motors' sweeps: where the catalogue stops
"$TC" lab walk "${SWEEPS[@]}" --model curve --json > "$OUT/lab_walk_all.json"
jq -r '"all four motors: " + (.walk | map("\(.model) \((.rmse_g * 1000 | round) / 1000) g") | join(" -> ")) +
       "; noise \((.noise_g * 1000 | round) / 1000) g; \(.verdict)"' "$OUT/lab_walk_all.json"
jq '.ladder' "$OUT/lab_walk.json" > "$OUT/lab_ladder.json"

say "swap experiment (issue 19): motor 1 replaced, only slot 1 recalibrated, fly's 10-degree steps with the same gains"
# The reduced run (one IMU unit, PD gains, every mode; the full one is docs/fly.md's, about 3 min
# on one core): four stock motors and each swapped part calibrated with gather_store, fly's steps
# on the seesaw and the gimbal. Prints the table, the targets of force and force+dyn mode (force
# with each motor's dynamics in its record and fly's `dyn on`: equal dynamics, issue 26) and the
# motors' time constants; every run's time series in $OUT/swap/series. The dynamics here are the
# plant's own (--dyn-from plant: seven gather_store dyn sessions would add about 50 s; the next
# step shows dyn measuring them within a few percent); the force+dyn flights add about 6.5 s
# (15.0 -> 21.5 s for this step with 2 jobs).
"$TC" sim swap --imu-seeds 1 --gains pd --jobs "$JOBS" --dyn-from plant --out-dir "$OUT/swap" --no-plots \
  --json "$OUT/swap.json" 2> >(sed -u 's/^/   /' >&2) | tee "$OUT/swap.txt"
# One plot: the gimbal's roll step (motor 1 sits on the roll axis) in each mode, stock and the
# three parts overlaid.
gnuplot <<GP
set datafile separator ","
set datafile commentschars "#"
set terminal pngcairo size 1400,1000 noenhanced font ",11"
set output "$OUT/swap_steps.png"
set multiplot layout 2,3 title "Swap: gimbal roll, 10-degree step, PD gains, IMU unit 1; stock and motor 1 replaced (slot 1 recalibrated)"
do for [mode in "force force+dyn generic pwm ardupilot"] {
  set title "mode ".mode; set xlabel "t from the step [s]"; set ylabel "roll (true) [deg]"
  set key right bottom; set grid; set autoscale y
  f(p) = sprintf("$OUT/swap/series/gimbal_%s_pd_%s_roll_s1.csv", mode, p)
  plot for [p in "stock kv1100_9x4.7 kv900_11x4.7 prop-8pct"] f(p) using 1:3 with lines lw 2 title p, \
       f("stock") using 1:2 with lines dt 2 lc rgb "black" title "setpoint"
}
unset multiplot
GP

say "dynamics (issue 26): gather_store's dyn cell and dyn, measured time constants against the plant's"
# Two parts side by side (about 20 s of wall each, in parallel): a stock motor (seed 11) and the
# KV900 part of the swap. Each: dyn cell, a calibration sweep, store v2, dyn; step logs kept.
"$TC" sim dyn --part stock --seed 11 --log "$OUT/dyn_stock.csv" --json "$OUT/dyn_stock.json" \
  > "$OUT/dyn_stock.txt" 2> >(sed -u 's/^/   /' >&2) &
dyn_stock=$!
"$TC" sim dyn --part kv900_11x4.7 --log "$OUT/dyn_kv900.csv" --json "$OUT/dyn_kv900.json" \
  > "$OUT/dyn_kv900.txt" 2> >(sed -u 's/^/   /' >&2)
wait "$dyn_stock"
for part in stock kv900; do
  echo "dyn, part $part (tau: gather_store's fit, plant: thrustcal plant step for the same pulses and bus)"
  cat "$OUT/dyn_$part.txt"
done

wall_s=$(( $(date +%s) - t0 ))
jq -n --slurpfile g "$OUT/gather.json" --slurpfile l "$OUT/liftoff.json" \
      --slurpfile g2 "$OUT/gather_v2.json" --slurpfile l2 "$OUT/liftoff_v2.json" \
      --slurpfile d "$OUT/lab_diagnose.json" --slurpfile la "$OUT/lab_ladder.json" \
      --slurpfile w "$OUT/lab_walk.json" --slurpfile wa "$OUT/lab_walk_all.json" \
      --slurpfile sw "$OUT/swap.json" --argjson wall "$wall_s" '
  {
    calibration: ($g[0].calibration + {v2: $g2[0].calibration.v2}),
    liftoff: ($l[0].liftoff + {v2: $l2[0].liftoff.v2}),
    lab: {diagnose: $d[0], ladder: $la[0],
          walk: ($w[0] | del(.ladder)), walk_all_motors: ($wa[0] | del(.ladder))},
    sim: {
      realtime_factor: ([$g[0].sim.realtime_factor, $l[0].sim.realtime_factor,
                         $g2[0].sim.realtime_factor, $l2[0].sim.realtime_factor,
                         $sw[0].sim.realtime_factor] | min),
      steps: {gather: $g[0].sim.realtime_factor, liftoff: $l[0].sim.realtime_factor,
              gather_v2: $g2[0].sim.realtime_factor, liftoff_v2: $l2[0].sim.realtime_factor,
              swap: $sw[0].sim.realtime_factor},
      gather: $g[0].sim, liftoff: $l[0].sim,
      demo_wall_s: $wall
    }
  }' > "$OUT/summary.json"

say "summary"
jq -r '
  def r(x): (x * 100 | round) / 100;
  . as $root |
  "calibration: stored curves vs the plant, max error \(r(.calibration.curve_error_max_g)) g (thesis curves), \(r(.calibration.v2.curve_error_max_g)) g (model v2)",
  "",
  "lift-off 300 g per motor           thrust per motor [g]              spread    rms error   max tilt",
  ({"calibrated": "calibrated, thesis", "v2": "calibrated, v2", "uncalibrated": "uncalibrated"} | to_entries[] |
    .value as $name | $root.liftoff[.key] as $x |
    "  \($name + "                    " | .[0:20])  \($x.hold_thrust_g | map(r(.) | tostring) | join("  "))   \(r($x.thrust_spread_pct)) %    \(r($x.force_error_rms_pct)) %     \(r($x.max_tilt_deg)) deg"),
  "",
  "lab: thesis model rmse \(r(.lab.diagnose.rmse_g)) g over \(.lab.diagnose.n) samples; first suspect: \(.lab.diagnose.suspects[0].variable // "none") -> \(if ((.lab.diagnose.suspects[0].effects // []) | length) > 0 then (.lab.diagnose.suspects[0].effects | join(", ")) else (.lab.diagnose.suspects[0].advice // "no effect named") end)",
  "lab walk (slot 0, the thesis bench): " + (.lab.walk.walk | map("\(.model) \(r(.rmse_g)) g") | join("  ->  ")) +
    "; noise floor \(r(.lab.walk.noise_g)) g: \(.lab.walk.verdict)",
  "",
  "simulator: at least \(r(.sim.realtime_factor))x real time (" +
    (.sim.steps | to_entries | map("\(.key) \(r(.value))x") | join(", ")) + "); demo took \(.sim.demo_wall_s) s"
' "$OUT/summary.json"
echo
echo "files: $OUT/summary.json, $OUT/force_curves.png, $OUT/liftoff_thrust.png, $OUT/lab/report.md"
echo "swap: $OUT/swap.txt (table, targets, time constants), $OUT/swap.json, $OUT/swap_steps.png, $OUT/swap/series/*.csv"
echo "dynamics: $OUT/dyn_{stock,kv900}.{txt,json,csv} (table, stored dynamics, step logs)"

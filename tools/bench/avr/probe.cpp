// AVR probe for `thrustcal bench compute|footprint`, built with avr-g++ by tools/bench's
// CMakeLists (the AVR tree's flags) and run in simavr by src/avr_probe.cpp with
// sim::runCycleProbe: each measured call sits between probe::markStart and probe::markEnd, and
// sizes and checks are reported under keys (sim/cycle_probe_avr.hpp).
// Every section is a call read_run makes, with the types read_run flies (core's, its slots'
// tc::SlotModel included):
//   - tc::V2Frame::fly, the frame read_run calls for its v2 motors (bus filter, sag prediction,
//     four pulses; the lanes' commands set as read_run's setForce sets them);
//   - the v1 (thesis) motor as read_run's flyMotor flies it: the sag-compensated reading and
//     tc::forceToPwm over tc::ThesisRun, its curves' steps read from the EEPROM through the
//     real hal::Eeprom (hal/avr/eeprom.cpp is linked in);
//   - the battery readings: the median of 101 (v1, status) and the middle two of four (v2);
//   - equal dynamics (`dyn on`): tc::DynShaper::stepAll over four motors, as the force API shapes each
//     motor's command before the frame above.
// The frame's assembly is also checked against its portable C++ (V2Frame::flyPortable) on
// frames with insane readings and jumps, and at the edges of the range (3.0 and 26.0 V, a 5 g
// and a 5 kg motor) (key kFrameMismatches must read 0).
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <string.h>

#include "hal/hal.hpp"
#include "sim/cycle_probe_avr.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/dyn_shaper.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/median_filter.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/model_v2_runtime.hpp"
#include "thrustcal/slot_model.hpp"
#include "thrustcal/thesis_runtime.hpp"

enum Label : uint8_t {
  kEmpty = 0,          // marker overhead
  kV2Frame = 1,        // V2Frame::fly: bus filter + 4 motors + sag prediction (commands change)
  kV2Steady = 2,       // V2Frame::fly with the same commands every frame (prediction settled)
  kThesis = 3,         // 4 x (sag-compensated reading + forceToPwm over ThesisRun)
  kThesisMedian = 4,   // thesis battery reading: 4 pushes into the median of 101 + median()
  kV2Reading = 5,      // v2 battery reading: the middle two of four readings in mV
  kShaping = 6,        // equal dynamics: DynShaper::stepAll, 4 motors (commands change every frame)
};
enum Key : uint8_t {
  kSizeofModelV2 = 0x80,
  kSizeofMotorCalibration = 0x81,
  kSizeofSlotModel = 0x82,
  kFitFailures = 0x83,
  kFrames = 0x84,
  kSizeofModelV2Run = 0x85,
  kSizeofThesisRun = 0x86,
  // 0x87 was sizeof(rr::Motor): read_run's private struct, no longer measured here
  kSizeofV2Frame = 0x88,
  kFrameMismatches = 0x89,
  kFramesChecked = 0x8A,
};

using probe::markEnd;
using probe::markStart;
static void report(uint8_t key, uint16_t value) { probe::report16(key, value); }
// Keeps a value in a register across the markers: inputs are computed before the start.
template <class T>
static inline void ready(const T& v) { __asm__ volatile("" ::"r"(v) : "memory"); }

// read_run's storage: four slots and the frame of its v2 motors (the symbols' sizes are what
// the image holds).
tc::SlotModel bench_slots[4];
tc::V2Frame bench_frame;
static tc::ModelV2 models[4];
static tc::MotorCalibration decoded;  // one at a time, as read_run's loader
static tc::ModelV2Fitter<81> fitter;
static tc::CurveBuilder<81> builder;
static tc::MedianFilter<101> battery_median;
static const tc::BatteryMonitor monitor;
static tc::V2Frame reference;
static tc::DynShaper shapers[4];
static tc::DynShaper* const shaper_ptrs[4] = {&shapers[0], &shapers[1], &shapers[2], &shapers[3]};
static const uint16_t kShapingMaxDg[4] = {7000, 7000, 7000, 7000};
static tc::ShaperReferenceTable shaper_reference;
volatile uint16_t sink;

// Integer synthetic motor: force ~ ((pwm - start) * V)^2, about 700 g at 1800 us and 12.4 V.
static int16_t forceDg(uint16_t pwm, uint8_t m, uint16_t vbat_mv) {
  const uint16_t start = static_cast<uint16_t>(1088 + 5 * m);
  if (pwm <= start) return 0;
  const uint32_t d = static_cast<uint32_t>(pwm - start) * vbat_mv / 12400;
  return static_cast<int16_t>(d * d / (70u + 3u * m));
}

// Sag the bench monitor sees: 60 mV per 100 g.
static uint16_t benchMv(uint16_t rest_mv, int16_t force_dg) {
  return static_cast<uint16_t>(rest_mv - static_cast<uint16_t>(force_dg) * 6u / 100u);
}

static uint16_t commandDg(uint16_t frame, uint8_t m) {
  return static_cast<uint16_t>(1000 + (frame * 131u + m * 877u) % 3501u);  // 100.0-450.0 g
}
static uint16_t busMv(uint16_t frame) {
  return static_cast<uint16_t>(12400 - frame + (frame * 37u) % 23u);  // draining, noisy
}

// Equal dynamics: four measured motors (about 89 ms light, 77 ms heavy, each a few ms apart),
// the slowest as the reference, at 400 Hz (fly's rate); one DynShaper::stepAll over the four per
// frame, as the force API makes it. Its own function, so main's measured code keeps its registers.
// Returns the failures (a reference that could not be built).
__attribute__((noinline)) static uint16_t measureShaping(uint16_t frames) {
  uint16_t failures = 0;
  tc::MotorDynamics laws[4];
  const tc::MotorDynamics* law_ptrs[4];
  for (uint8_t m = 0; m < 4; ++m) {
    laws[m].points = 5;
    laws[m].lo_dg = 1000;
    laws[m].hi_dg = 4000;
    laws[m].up_lo_01ms = static_cast<uint16_t>(890 - 40 * m);
    laws[m].up_hi_01ms = static_cast<uint16_t>(770 - 30 * m);
    laws[m].down_lo_01ms = static_cast<uint16_t>(900 - 40 * m);
    laws[m].down_hi_01ms = static_cast<uint16_t>(790 - 30 * m);
    law_ptrs[m] = &laws[m];
  }
  if (!tc::buildShaperReference(shaper_reference, tc::ShaperReference(), law_ptrs, 4, 7000, 400)) ++failures;
  for (uint8_t m = 0; m < 4; ++m) shapers[m].configure(laws[m], shaper_reference, 400, 2000);
  for (uint16_t frame = 0; frame < frames; ++frame) {
    uint16_t shaped[4];
    uint16_t commands[4];
    for (uint8_t m = 0; m < 4; ++m) commands[m] = commandDg(frame, m);
    ready(commands[3]);
    markStart(kShaping);
    tc::DynShaper::stepAll(shaper_ptrs, commands, kShapingMaxDg, shaped, 4, shaper_reference);
    markEnd();
    sink = shaped[0] + shaped[3];
  }
  return failures;
}

// One frame of bench_frame through the assembly and, from the same state, through the portable
// C++: true when both leave the same filters, pulses and flags.
static bool flyBothSame(uint16_t mv, uint8_t extra) {
  memcpy(&reference, &bench_frame, sizeof reference);
  reference.flyPortable(mv, extra);
  bench_frame.fly(mv, extra);
  bool same = memcmp(&reference.bus, &bench_frame.bus, sizeof reference.bus) == 0 &&
              reference.sag.seen_q4 == bench_frame.sag.seen_q4 &&
              reference.sag.rem == bench_frame.sag.rem && reference.sag.last_q4 == bench_frame.sag.last_q4;
  for (uint8_t m = 0; m < 4; ++m)
    same = same && reference.lane[m].pwm_us == bench_frame.lane[m].pwm_us &&
           reference.lane[m].flags == bench_frame.lane[m].flags;
  return same;
}

// The whole measurement, in order: sizes, the thesis slots and frames, the v2 slots and frames,
// then the assembly against the portable frame.
// long: AVR code whose measured sections include the code around each call; split into
// functions, the same calls measured longer (register moves around them), so it stays one run
int main() {
  markStart(kEmpty);
  markEnd();
  report(kSizeofModelV2, sizeof(tc::ModelV2));
  report(kSizeofMotorCalibration, sizeof(tc::MotorCalibration));
  report(kSizeofSlotModel, sizeof(tc::SlotModel));
  report(kSizeofModelV2Run, sizeof(tc::ModelV2Run));
  report(kSizeofThesisRun, sizeof(tc::ThesisRun));
  report(kSizeofV2Frame, sizeof(tc::V2Frame));
  uint16_t failures = 0;
  const uint16_t kFramesRun = 500;

  // ---- thesis: two curves (12.4 V, 10.5 V) and the sag table per motor, written to the
  // EEPROM as gather_store writes them, loaded into the slots as read_run loads them ----------
  for (uint8_t m = 0; m < 4; ++m) {
    decoded.clear();
    const uint16_t rests[2] = {12400, 10500};
    for (uint8_t c = 0; c < 2; ++c) {
      builder.reset();
      tc::SagBuilder sag;
      sag.reset(1000);
      for (uint16_t p = 1000; p <= 1800; p += 10) {
        const int16_t f = forceDg(p, m, rests[c]);
        builder.add(p, f);
        sag.add(p, benchMv(rests[c], f));
      }
      tc::ThesisCurve& curve = c == 0 ? decoded.first : decoded.second;
      if (builder.build(curve).status != tc::BuildStatus::kOk) ++failures;
      uint16_t start_mv = 0;
      tc::SagTable second_sag;  // gather_store keeps only the first sweep's offsets
      sag.build(c == 0 ? decoded.sag : second_sag, start_mv);
      curve.start_mv = start_mv;
    }
    tc::writeRecord<hal::Eeprom>(m, decoded);
    if (tc::readRecord<hal::Eeprom>(m, decoded) != tc::DecodeStatus::kOk) ++failures;
    if (!bench_slots[m].setV1<hal::Eeprom>(decoded, m)) ++failures;
  }
  for (uint8_t k = 0; k < 101; ++k) battery_median.push(793);  // ~12.1 V
  uint16_t pwm[4] = {1000, 1000, 1000, 1000};
  for (uint16_t frame = 0; frame < kFramesRun; ++frame) {
    const uint16_t counts = static_cast<uint16_t>(793 - frame / 8 + (frame * 7u) % 3u);
    uint16_t force_g[4];
    for (uint8_t m = 0; m < 4; ++m) force_g[m] = static_cast<uint16_t>(commandDg(frame, m) / 10u);
    ready(counts);
    markStart(kThesisMedian);
    for (uint8_t k = 0; k < 4; ++k) battery_median.push(static_cast<uint16_t>(counts + k % 2));
    const uint16_t battery_mv = monitor.millivoltsFromCounts(battery_median.median());
    markEnd();
    ready(battery_mv);
    markStart(kThesis);
    for (uint8_t m = 0; m < 4; ++m) {  // read_run's flyMotor, v1 branch
      const tc::ThesisRun& thesis = bench_slots[m].v1();
      const uint16_t mv = monitor.compensatedMillivolts(battery_mv, pwm[m], thesis.sag);
      pwm[m] = tc::forceToPwm<hal::Eeprom>(thesis, force_g[m], mv).pwm_us;
    }
    markEnd();
    sink = pwm[3];
    // the v2 battery reading: four readings, the middle two in mV (read_run's middleTwoMillivolts)
    const uint16_t four[4] = {counts, static_cast<uint16_t>(counts + 1), static_cast<uint16_t>(counts - 2),
                              static_cast<uint16_t>(counts + 30)};
    ready(four[3]);
    markStart(kV2Reading);
    uint16_t sum = 0, lo = 0xFFFF, hi = 0;
    for (uint8_t k = 0; k < 4; ++k) {
      const uint16_t c = four[k] < 1023 ? four[k] : 1023;
      sum = static_cast<uint16_t>(sum + c);
      if (c < lo) lo = c;
      if (c > hi) hi = c;
    }
    sink = monitor.millivoltsFromTwoCounts(static_cast<uint16_t>(sum - lo - hi));
    markEnd();
  }

  // ---- v2: one sweep at 12.4 V, refined by one at 10.5 V, per motor; the slots and the frame
  // as read_run's loader sets them -------------------------------------------------------------
  bench_frame.count = 0;
  for (uint8_t m = 0; m < 4; ++m) {
    fitter.reset();
    for (uint16_t p = 1000; p <= 1800; p += 10) {
      const int16_t f = forceDg(p, m, 12400);
      fitter.add(p, f, benchMv(12400, f));
    }
    if (fitter.fit(models[m]).status != tc::FitV2Status::kOk) ++failures;
    fitter.reset();
    for (uint16_t p = 1000; p <= 1800; p += 10) {
      const int16_t f = forceDg(p, m, 10500);
      fitter.add(p, f, benchMv(10500, f));
    }
    if (fitter.refine(models[m]).status != tc::FitV2Status::kOk) ++failures;
    if (!bench_slots[m].setV2(models[m])) ++failures;
    bench_frame.lane[bench_frame.count++].setModel(&bench_slots[m].v2());
  }
  bench_frame.bus.reset(busMv(0));  // read_run's filter has been running since arming
  for (uint16_t frame = 0; frame < kFramesRun; ++frame) {
    for (uint8_t m = 0; m < 4; ++m) bench_frame.lane[m].force_dg = commandDg(frame, m);  // setForce
    const uint16_t mv = busMv(frame);
    ready(mv);
    markStart(kV2Frame);
    bench_frame.fly(mv, 0);
    markEnd();
    sink = bench_frame.lane[3].pwm_us;
  }
  failures = static_cast<uint16_t>(failures + measureShaping(kFramesRun));
  for (uint16_t frame = 0; frame < kFramesRun; ++frame) {
    for (uint8_t m = 0; m < 4; ++m) bench_frame.lane[m].force_dg = static_cast<uint16_t>(1500 + 500 * m);
    const uint16_t mv = busMv(kFramesRun + frame);
    ready(mv);
    markStart(kV2Steady);
    bench_frame.fly(mv, 0);
    markEnd();
    sink = bench_frame.lane[3].pwm_us;
  }

  // ---- the assembly against the portable frame: same state in, same state out ---------------
  uint16_t mismatches = 0, checked = 0;
  bench_frame.bus = tc::BusVoltageFilter();
  bench_frame.sag = tc::BusSagFilter();
  for (uint16_t frame = 0; frame < 2000; ++frame) {
    for (uint8_t m = 0; m < 4; ++m) {
      bench_frame.lane[m].force_dg = (frame % 50 < 3) ? 0 : static_cast<uint16_t>((frame * 131u + m * 877u) % 9000u);
    }
    uint16_t mv = static_cast<uint16_t>(12600 - frame + (frame * 37u) % 23u);
    if (frame % 97 == 50) mv = 1500;      // wire off: rejected, flagged
    if (frame % 400 == 300) mv = 9000;    // a jump: re-seeded by division
    if (frame == 1500) bench_frame.bus.shift = 6;  // 400 Hz
    if (frame == 1800) bench_frame.bus.shift = 0;  // no filtering
    const uint8_t extra = (frame % 7 == 0) ? tc::kVoltageInvalid : 0;
    if (!flyBothSame(mv, extra)) ++mismatches;
    ++checked;
  }

  // ---- the same at the edges of the range model v2 accepts (1S..6S, 5 g..5 kg): a 5 g motor
  // (one run of 2 dg steps: the Q16 knot position), a 5 kg one (its largest knot at 50000 dg)
  // and two fitted above; bus readings from 3.0 to 26.0 V, jumps between the ends (re-seeds)
  static const uint16_t kEdgeMv[] = {3000, 3001, 3000, 4200, 8400, 12600, 16800, 21000,
                                     25200, 26000, 25999, 26000, 3000, 26000, 3000, 3100};
  for (uint8_t e = 0; e < 2; ++e) {
    tc::ModelV2& mdl = models[e];
    mdl.clear();
    mdl.start_q4_us = e == 0 ? 1050u * 16u : 1120u * 16u;
    mdl.rest_mv = e == 0 ? 4100 : 25000;
    if (e == 0) {  // 5 g: one run, step 2 dg, 25 knots
      mdl.step_dg = 2;
      mdl.knots = 25;
      mdl.fine_knots = 25;
    } else {  // 5 kg: 16 fine knots of 781 dg, 16 coarse of 2344 dg
      mdl.step_dg = 781;
      mdl.knots = 32;
      mdl.fine_knots = 16;
      mdl.coarse_step_dg = 2344;
    }
    for (uint8_t k = 0; k < mdl.knots; ++k) {
      // rising drive: 8600 at the last knot (5 g), 44590 (5 kg: ~900 us above start at 25 V)
      mdl.drive_512usmv[k] = static_cast<uint16_t>(e == 0 ? 200u + 350u * k : 1500u + 1390u * k);
      mdl.sag_10mv[k] = static_cast<uint8_t>(e == 0 ? k : 7u * k);
    }
    if (!mdl.finalize()) ++failures;
    if (!bench_slots[e].setV2(mdl)) ++failures;
    bench_frame.lane[e].setModel(&bench_slots[e].v2());
  }
  bench_frame.bus = tc::BusVoltageFilter();
  bench_frame.sag = tc::BusSagFilter();
  for (uint16_t frame = 0; frame < 1200; ++frame) {
    for (uint8_t m = 0; m < 4; ++m) {
      const uint16_t top = static_cast<uint16_t>(bench_slots[m].v2().max_force_dg + 40u);
      bench_frame.lane[m].force_dg =
          (frame % 50 < 2) ? 0 : static_cast<uint16_t>((frame * (m == 1 ? 977u : 7u) + m * 13u) % top);
    }
    uint16_t mv = kEdgeMv[(frame / 8) % (sizeof kEdgeMv / sizeof kEdgeMv[0])];
    if (frame % 3 == 1) mv = static_cast<uint16_t>(mv + (mv < 26000 ? frame % 5 : 0) - (mv > 3000 ? frame % 7 : 0));
    if (frame % 89 == 40) mv = frame % 2 ? 2999 : 26001;  // just outside: rejected, flagged
    if (frame == 600) bench_frame.bus.shift = 6;
    if (frame == 900) bench_frame.bus.shift = 0;
    const uint8_t extra = (frame % 11 == 0) ? tc::kVoltageInvalid : 0;
    if (!flyBothSame(mv, extra)) ++mismatches;
    ++checked;
  }

  report(kFitFailures, failures);
  report(kFrames, kFramesRun);
  report(kFrameMismatches, mismatches);
  report(kFramesChecked, checked);
  probe::done();
  cli();
  sleep_enable();
  sleep_cpu();
}

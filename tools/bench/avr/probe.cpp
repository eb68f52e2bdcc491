// AVR probe for `thrustcal bench compute|footprint`, built with avr-g++ by tools/bench's
// CMakeLists (same flags as the AVR tree) and run in libsimavr by src/avr_probe.cpp.
// Same marker approach as tests/core_v2/avr_cycles: the host timestamps GPIOR writes with the
// simulated cycle counter.
//   GPIOR1 = label, GPIOR0 = 1 (start) ... GPIOR0 = 2 (end)       a measured section
//   GPIOR1 = 0x80 + key, GPIOR2 = low byte, GPIOR2 = high byte     a value (sizes, checks)
//   GPIOR1 = 0xFF                                                  done
// One four-motor update is measured the way read_run's flyMotor() computes it (read_run's
// ReadRunApp is not linkable without its HAL, so the per-motor path is repeated here, calling
// the same core/ functions on read_run's own per-motor storage, rr::SlotModel).
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "slot_model.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/median_filter.hpp"
#include "thrustcal/model_v2.hpp"

enum Label : uint8_t {
  kEmpty = 0,          // marker overhead
  kV2ReadRun = 1,      // bus filter update + 4 x forceToPwmV2 with sag prediction (read_run)
  kV2Frame = 2,        // bus filter update + forceToPwmV2Frame (four motors, one call)
  kThesis = 3,         // 4 x (sag-compensated reading + forceToPwm), option 2.1
  kThesisMedian = 4,   // thesis battery reading: 4 pushes into the median of 101 + median()
};
enum Key : uint8_t {
  kSizeofModelV2 = 0x80,
  kSizeofMotorCalibration = 0x81,
  kSizeofSlotModel = 0x82,
  kFitFailures = 0x83,
  kFrames = 0x84,
};

static inline void markStart(uint8_t label) { GPIOR1 = label; GPIOR0 = 1; }
static inline void markEnd() { GPIOR0 = 2; }
static void report(uint8_t key, uint16_t value) {
  GPIOR1 = key;
  GPIOR2 = static_cast<uint8_t>(value);
  GPIOR2 = static_cast<uint8_t>(value >> 8);
}

// read_run's storage: four slots, each v1 or v2 (the symbol's size is what the image holds).
rr::SlotModel bench_slots[4];
// The four v2 models alone (what a v2-only read_run would hold).
tc::ModelV2 bench_models_v2[4];
static tc::ModelV2Fitter<81> fitter;
static tc::CurveBuilder<81> builder;
static tc::MedianFilter<101> battery_median;
static const tc::ForcePwmLimits limits;
static const tc::BatteryMonitor monitor;
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

int main() {
  markStart(kEmpty);
  markEnd();
  report(kSizeofModelV2, sizeof(tc::ModelV2));
  report(kSizeofMotorCalibration, sizeof(tc::MotorCalibration));
  report(kSizeofSlotModel, sizeof(rr::SlotModel));
  uint16_t failures = 0;
  const uint16_t kFramesRun = 500;

  // ---- thesis: two curves (12.4 V, 10.5 V) and the sag table per motor, in the slots ----------
  for (uint8_t m = 0; m < 4; ++m) {
    tc::MotorCalibration& cal = bench_slots[m].resetToV1();
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
      tc::ThesisCurve& curve = c == 0 ? cal.first : cal.second;
      if (builder.build(curve).status != tc::BuildStatus::kOk) ++failures;
      uint16_t start_mv = 0;
      tc::SagTable second_sag;  // gather_store keeps only the first sweep's offsets
      sag.build(c == 0 ? cal.sag : second_sag, start_mv);
      curve.start_mv = start_mv;
    }
  }
  for (uint8_t k = 0; k < 101; ++k) battery_median.push(793);  // ~12.1 V
  uint16_t pwm[4] = {1000, 1000, 1000, 1000};
  for (uint16_t frame = 0; frame < kFramesRun; ++frame) {
    const uint16_t counts = static_cast<uint16_t>(793 - frame / 8 + (frame * 7u) % 3u);
    markStart(kThesisMedian);
    for (uint8_t k = 0; k < 4; ++k) battery_median.push(static_cast<uint16_t>(counts + k % 2));
    const uint16_t battery_mv = monitor.millivoltsFromCounts(battery_median.median());
    markEnd();
    markStart(kThesis);
    for (uint8_t m = 0; m < 4; ++m) {
      const tc::MotorCalibration& cal = bench_slots[m].v1();
      const uint16_t mv = monitor.compensatedMillivolts(battery_mv, pwm[m], cal.sag);
      pwm[m] = tc::forceToPwm(cal, commandDg(frame, m) / 10u, mv, limits).pwm_us;
    }
    markEnd();
    sink = pwm[3];
  }

  // ---- v2: one sweep at 12.4 V, refined by one at 10.5 V, per motor -------------------------
  for (uint8_t m = 0; m < 4; ++m) {
    fitter.reset();
    for (uint16_t p = 1000; p <= 1800; p += 10) {
      const int16_t f = forceDg(p, m, 12400);
      fitter.add(p, f, benchMv(12400, f));
    }
    if (fitter.fit(bench_models_v2[m]).status != tc::FitV2Status::kOk) ++failures;
    fitter.reset();
    for (uint16_t p = 1000; p <= 1800; p += 10) {
      const int16_t f = forceDg(p, m, 10500);
      fitter.add(p, f, benchMv(10500, f));
    }
    if (fitter.refine(bench_models_v2[m]).status != tc::FitV2Status::kOk) ++failures;
    bench_slots[m].setV2(bench_models_v2[m]);
  }
  tc::BusVoltageFilter bus;
  bus.reset(busMv(0));
  uint32_t seen_acc[4] = {0, 0, 0, 0};
  uint16_t cmd[4];
  tc::ForcePwmResult out[4];
  for (uint16_t frame = 0; frame < kFramesRun; ++frame) {
    for (uint8_t m = 0; m < 4; ++m) cmd[m] = commandDg(frame, m);
    // read_run's flyMotor() for four v2 slots
    markStart(kV2ReadRun);
    bus.update(busMv(frame));
    for (uint8_t m = 0; m < 4; ++m) {
      const uint16_t seen_dg = static_cast<uint16_t>(seen_acc[m] >> bus.shift);
      const tc::ForcePwmResult r = tc::forceToPwmV2(bench_slots[m].v2(), cmd[m], bus, seen_dg, limits);
      seen_acc[m] = seen_acc[m] - (seen_acc[m] >> bus.shift) + cmd[m];
      pwm[m] = r.pwm_us;
    }
    markEnd();
    sink = pwm[3];
    markStart(kV2Frame);
    bus.update(busMv(frame));
    tc::forceToPwmV2Frame(bench_models_v2, cmd, 4, bus, out, limits);
    markEnd();
    sink = out[3].pwm_us;
  }
  report(kFitFailures, failures);
  report(kFrames, kFramesRun);
  GPIOR1 = 0xFF;
  cli();
  sleep_enable();
  sleep_cpu();
}

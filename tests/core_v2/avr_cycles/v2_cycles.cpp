// AVR side of the cycle benchmark (tests/core_v2/avr_cycles.sh): runs model v2 (and the
// thesis controller for comparison) between marker writes that the libsimavr host program
// (run_cycles.cpp) timestamps with the simulated cycle counter.
//   GPIOR1 = label, then GPIOR0 = 1 (start) ... GPIOR0 = 2 (end); GPIOR2 = 0xEE: done.
#include <avr/io.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>

#include "thrustcal/curve_builder.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/motor_calibration.hpp"

enum Label : uint8_t {
  kEmpty = 0,         // marker overhead
  kV2Frame = 1,       // bus filter update + forceToPwmV2Frame (four motors)
  kV2SagFrame = 2,    // bus filter update + forceToPwmV2 with sag prediction x4
  kThesisFrame = 3,   // forceToPwm (option 2.1, two curves) x4
  kV2SingleCalls = 4, // bus filter update + forceToPwmV2 x4 (one call per motor)
  kFilterUpdate = 5,  // bus filter update alone
  kFit = 10,          // ModelV2Fitter::fit, one 101-sample sweep (labels 10..13)
  kRefine = 20,       // ModelV2Fitter::refine, one sweep
};

static inline void markStart(uint8_t label) {
  GPIOR1 = label;
  GPIOR0 = 1;
}
static inline void markEnd() { GPIOR0 = 2; }

static tc::ModelV2 models[4];
static tc::ModelV2Fitter<101> fitter;
static tc::MotorCalibration cal;
static tc::CurveBuilder<101> builder;
static const tc::ForcePwmLimits limits;  // read_run holds one; not rebuilt per call
volatile uint16_t sink;

// Integer synthetic motor: force ~ ((pwm - start) * V)^2, ~900 g at full throttle at 12.4 V.
static int16_t forceDg(uint16_t pwm, uint16_t start, uint16_t vbat_mv, uint8_t m) {
  if (pwm <= start) return 0;
  const uint32_t d = static_cast<uint32_t>(pwm - start) * vbat_mv / 12400;  // us at 12.4 V
  return static_cast<int16_t>(d * d / (88u + 3u * m));
}

static void sweep(uint8_t m, uint16_t vbat_mv) {
  const uint16_t start = static_cast<uint16_t>(1088 + 6 * m);
  fitter.reset();
  for (uint16_t p = 1000; p <= 2000; p += 10) fitter.add(p, forceDg(p, start, vbat_mv, m), vbat_mv);
}

int main() {
  markStart(kEmpty);
  markEnd();
  for (uint8_t m = 0; m < 4; ++m) {
    sweep(m, 12400);
    markStart(static_cast<uint8_t>(kFit + m));
    const tc::FitV2Report rep = fitter.fit(models[m]);
    markEnd();
    if (rep.status != tc::FitV2Status::kOk) GPIOR2 = 0xE0;  // the host reports a failed fit
  }
  sweep(0, 10500);
  markStart(kRefine);
  fitter.refine(models[0]);
  markEnd();
  sink = models[0].start_q4_us;

  // Thesis calibration of motor 0: curves at 12.4 V and 10.5 V.
  builder.reset();
  for (uint16_t p = 1000; p <= 2000; p += 10) builder.add(p, forceDg(p, 1088, 12400, 0));
  builder.build(cal.first);
  cal.first.start_mv = 12400;
  builder.reset();
  for (uint16_t p = 1000; p <= 2000; p += 10) builder.add(p, forceDg(p, 1088, 10500, 0));
  builder.build(cal.second);
  cal.second.start_mv = 10500;

  tc::BusVoltageFilter bus;
  bus.reset(12400);
  uint16_t cmd_dg[4], now_dg[4] = {0, 0, 0, 0};
  tc::ForcePwmResult out[4];
  for (uint16_t frame = 0; frame < 1000; ++frame) {
    const uint16_t sample_mv = static_cast<uint16_t>(12400 - 2 * frame + (frame * 37u) % 23u);
    for (uint8_t m = 0; m < 4; ++m)
      cmd_dg[m] = static_cast<uint16_t>(1000 + (frame * 13u + m * 700u) % 3500u);

    markStart(kV2Frame);
    bus.update(sample_mv);
    tc::forceToPwmV2Frame(models, cmd_dg, 4, bus, out, limits);
    markEnd();
    sink = out[3].pwm_us;

    markStart(kV2SingleCalls);
    bus.update(sample_mv);
    for (uint8_t m = 0; m < 4; ++m) sink = tc::forceToPwmV2(models[m], cmd_dg[m], bus, limits).pwm_us;
    markEnd();

    markStart(kFilterUpdate);
    bus.update(sample_mv);
    markEnd();

    markStart(kV2SagFrame);
    bus.update(sample_mv);
    for (uint8_t m = 0; m < 4; ++m)
      sink = tc::forceToPwmV2(models[m], cmd_dg[m], bus, now_dg[m], limits).pwm_us;
    markEnd();

    markStart(kThesisFrame);
    for (uint8_t m = 0; m < 4; ++m)
      sink = tc::forceToPwm(cal, static_cast<uint16_t>(cmd_dg[m] / 10), sample_mv, limits).pwm_us;
    markEnd();

    for (uint8_t m = 0; m < 4; ++m) now_dg[m] = cmd_dg[m];
  }
  GPIOR2 = 0xEE;
  cli();
  sleep_enable();
  sleep_cpu();
}

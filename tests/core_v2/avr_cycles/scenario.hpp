// The cycle benchmark's scenario, shared by the AVR program (v2_cycles.cpp, run in simavr)
// and the host program (scenario_host.cpp): four motors fitted from integer synthetic sweeps,
// one refined, then 1000 frames of a draining pack with varied commands through model v2
// (plain, frame call, sag prediction) and the thesis controller. Every result is emitted as
// bytes, so the AVR run (16-bit int) and the host run (32-bit int) can be compared byte for
// byte: integer code must give identical models and pulses on both.
//
// Io: static void markStart(uint8_t label); static void markEnd(); static void emit(uint8_t);
#pragma once
#include <stdint.h>

#include "thrustcal/curve_builder.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/model_v2_runtime.hpp"
#include "thrustcal/motor_calibration.hpp"
#include "thrustcal/record_v2.hpp"

namespace scenario {

enum Label : uint8_t {
  kEmpty = 0,         // marker overhead
  kV2Frame = 1,       // V2Frame::fly: bus filter + four motors + sag prediction (one call)
  kV2SagFrame = 2,    // bus filter update + forceToPwmV2 with sag prediction x4
  kThesisFrame = 3,   // forceToPwm (option 2.1, two curves) x4
  kV2SingleCalls = 4, // bus filter update + forceToPwmV2 x4 (one call per motor)
  kFilterUpdate = 5,  // bus filter update alone
  kFit = 10,          // ModelV2Fitter::fit, one 101-sample sweep (labels 10..13)
  kRefine = 20,       // ModelV2Fitter::refine, one sweep
};

// Integer synthetic motor: force ~ ((pwm - start) * V)^2, ~900 g at full throttle at 12.4 V.
inline int16_t forceDg(uint16_t pwm, uint16_t start, uint16_t vbat_mv, uint8_t m) {
  if (pwm <= start) return 0;
  const uint32_t d = static_cast<uint32_t>(pwm - start) * vbat_mv / 12400;  // us at 12.4 V
  return static_cast<int16_t>(d * d / (88u + 3u * m));
}

struct State {
  tc::ModelV2 models[4];
  tc::ModelV2Fitter<101> fitter;
  tc::MotorCalibration cal;
  tc::CurveBuilder<101> builder;
  tc::ForcePwmLimits limits;  // read_run holds one; not rebuilt per call
  tc::ModelV2Run runs[4];     // the models as read_run flies them
  tc::V2Frame frame;
};

template <class Io>
void emit16(uint16_t v) {
  Io::emit(static_cast<uint8_t>(v & 0xFF));
  Io::emit(static_cast<uint8_t>(v >> 8));
}

template <class Io>
void emitResult(const tc::ForcePwmResult& r) {
  emit16<Io>(r.pwm_us);
  Io::emit(r.flags);
}

template <class Io>
void sweep(State& s, uint8_t m, uint16_t vbat_mv) {
  const uint16_t start = static_cast<uint16_t>(1088 + 6 * m);
  s.fitter.reset();
  for (uint16_t p = 1000; p <= 2000; p += 10) {
    // The monitor sags with the force (~0.5-0.8 V at full force): nonzero sag tables, so the
    // sag prediction's arithmetic is compared between AVR and host too.
    const int16_t f = forceDg(p, start, vbat_mv, m);
    s.fitter.add(p, f, static_cast<uint16_t>(vbat_mv - static_cast<uint16_t>(f) / (12u + 2u * m)));
  }
}

template <class Io>
void run(State& s) {
  volatile uint16_t sink = 0;
  Io::markStart(kEmpty);
  Io::markEnd();
  for (uint8_t m = 0; m < 4; ++m) {
    sweep<Io>(s, m, 12400);
    Io::markStart(static_cast<uint8_t>(kFit + m));
    const tc::FitV2Report rep = s.fitter.fit(s.models[m]);
    Io::markEnd();
    Io::emit(static_cast<uint8_t>(rep.status));
  }
  sweep<Io>(s, 0, 10500);
  Io::markStart(kRefine);
  const tc::FitV2Report refined = s.fitter.refine(s.models[0]);
  Io::markEnd();
  Io::emit(static_cast<uint8_t>(refined.status));
  for (uint8_t m = 0; m < 4; ++m) {
    uint8_t image[tc::kRecordV2Bytes];
    tc::serializeModelV2(s.models[m], 0, image);
    for (uint16_t i = 0; i < tc::kRecordV2Bytes; ++i) Io::emit(image[i]);
  }

  // Thesis calibration of motor 0: curves at 12.4 V and 10.5 V.
  s.builder.reset();
  for (uint16_t p = 1000; p <= 2000; p += 10) s.builder.add(p, forceDg(p, 1088, 12400, 0));
  s.builder.build(s.cal.first);
  s.cal.first.start_mv = 12400;
  s.builder.reset();
  for (uint16_t p = 1000; p <= 2000; p += 10) s.builder.add(p, forceDg(p, 1088, 10500, 0));
  s.builder.build(s.cal.second);
  s.cal.second.start_mv = 10500;

  tc::BusVoltageFilter bus;
  bus.reset(12400);
  for (uint8_t m = 0; m < 4; ++m) {
    Io::emit(s.runs[m].load(s.models[m]) ? 1 : 0);
    s.frame.lane[m].setModel(&s.runs[m]);
  }
  s.frame.count = 4;
  s.frame.bus.reset(12400);
  uint16_t cmd_dg[4], now_dg[4] = {0, 0, 0, 0};
  tc::ForcePwmResult out[4];
  for (uint16_t frame = 0; frame < 1000; ++frame) {
    const uint16_t sample_mv = static_cast<uint16_t>(12400 - 2 * frame + (frame * 37u) % 23u);
    for (uint8_t m = 0; m < 4; ++m)
      cmd_dg[m] = static_cast<uint16_t>(1000 + (frame * 13u + m * 700u) % 3500u);

    for (uint8_t m = 0; m < 4; ++m) s.frame.lane[m].force_dg = cmd_dg[m];
    Io::markStart(kV2Frame);  // on the AVR the assembly, on the host the portable C++
    s.frame.fly(sample_mv);
    Io::markEnd();
    emit16<Io>(s.frame.bus.mv);
    emit16<Io>(s.frame.bus.recip_q27);
    emit16<Io>(s.frame.sag.last_q4);
    for (uint8_t m = 0; m < 4; ++m) emitResult<Io>(s.frame.lane[m].result());

    Io::markStart(kV2SingleCalls);
    bus.update(sample_mv);
    for (uint8_t m = 0; m < 4; ++m) out[m] = tc::forceToPwmV2(s.models[m], cmd_dg[m], bus, s.limits);
    Io::markEnd();
    for (uint8_t m = 0; m < 4; ++m) emitResult<Io>(out[m]);

    Io::markStart(kFilterUpdate);
    bus.update(sample_mv);
    Io::markEnd();

    Io::markStart(kV2SagFrame);
    bus.update(sample_mv);
    for (uint8_t m = 0; m < 4; ++m)
      out[m] = tc::forceToPwmV2(s.models[m], cmd_dg[m], bus, now_dg[m], s.limits);
    Io::markEnd();
    for (uint8_t m = 0; m < 4; ++m) emitResult<Io>(out[m]);

    Io::markStart(kThesisFrame);
    for (uint8_t m = 0; m < 4; ++m)
      out[m] = tc::forceToPwm(s.cal, static_cast<uint16_t>(cmd_dg[m] / 10), sample_mv, s.limits);
    Io::markEnd();
    for (uint8_t m = 0; m < 4; ++m) emitResult<Io>(out[m]);

    for (uint8_t m = 0; m < 4; ++m) now_dg[m] = cmd_dg[m];
  }
  emit16<Io>(tc::headroomDg(s.models[1], 10000));
  emit16<Io>(tc::forceForPwmDg(s.models[2], 1500, 11100));
  sink = bus.mv;
  (void)sink;
}

}  // namespace scenario

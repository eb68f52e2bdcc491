// Test support shared by the record tests: a RAM EEPROM that can lose power after any write,
// a measured-looking thesis record, and equality of loaded calibrations. Host only.
#pragma once
#include <stdint.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "synthetic_motor.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/motor_calibration.hpp"
#include "thrustcal/record_v2.hpp"

namespace tc_test {

// 4 KB EEPROM in RAM. updateByte skips equal bytes like the board's; a power cut is modelled
// by a budget of updateByte calls: once spent, writes are dropped, and the call that spends
// it may leave a torn byte (a garbage value) behind.
struct CutEeprom {
  static uint8_t bytes[4096];
  static uint32_t physical_writes;  // bytes whose value changed
  static uint32_t update_calls;
  static int32_t budget;  // calls still accepted; < 0: unlimited
  static int16_t torn;    // value left by the first refused call; < 0: none
  static void erase() {
    std::memset(bytes, 0xFF, sizeof bytes);
    physical_writes = 0;
    update_calls = 0;
    budget = -1;
    torn = -1;
  }
  static std::vector<uint8_t> image() { return std::vector<uint8_t>(bytes, bytes + sizeof bytes); }
  static void restore(const std::vector<uint8_t>& v) {
    std::memcpy(bytes, v.data(), sizeof bytes);
    update_calls = 0;
    budget = -1;
    torn = -1;
  }
  static uint8_t readByte(uint16_t addr) { return bytes[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) {
    ++update_calls;
    if (budget == 0) {
      if (torn >= 0) {
        bytes[addr] = static_cast<uint8_t>(torn);
        torn = -1;
      }
      return;
    }
    if (budget > 0) --budget;
    if (bytes[addr] != value) {
      bytes[addr] = value;
      ++physical_writes;
    }
  }
};
inline uint8_t CutEeprom::bytes[4096];
inline uint32_t CutEeprom::physical_writes = 0;
inline uint32_t CutEeprom::update_calls = 0;
inline int32_t CutEeprom::budget = -1;
inline int16_t CutEeprom::torn = -1;

// The thesis record of `motor` swept 1000..2000 us in 10 us steps at v1 volts (curve 1) and
// v2 volts (curve 2; 0: none), with a sag table rising 40 mV per bin.
inline tc::MotorCalibration thesisRecord(const SyntheticMotor& motor, double v1, double v2 = 0.0) {
  tc::MotorCalibration cal;
  for (int c = 0; c < (v2 > 0.0 ? 2 : 1); ++c) {
    const double v = c == 0 ? v1 : v2;
    tc::CurveBuilder<128> builder;
    for (uint16_t pwm = 1000; pwm <= 2000; pwm += 10)
      builder.add(pwm, static_cast<int16_t>(std::lround(motor.forceG(pwm, v) * 10)));
    tc::ForceCurveBase& curve = c == 0 ? static_cast<tc::ForceCurveBase&>(cal.first) : cal.second;
    builder.build(curve);
    curve.start_mv = static_cast<uint16_t>(std::lround(v * 1000));
    curve.finalize();
  }
  cal.sag.base_pwm_us = 1000;
  for (uint8_t i = 0; i < tc::kSagBins; ++i) cal.sag.offset_mv[i] = static_cast<int16_t>(i * 40);
  return cal;
}

// The v2 model of a synthetic motor fitted from one sweep at rest_v.
inline tc::ModelV2 motorModel(double exponent, double start_us, double rest_v) {
  SyntheticMotor motor;
  motor.exponent = exponent;
  motor.start_us = start_us;
  return fittedModel(motor, rest_v);
}

// `model` with measured-looking dynamics (thrustcal/dynamics.hpp): spin-up 92 -> 74 ms and
// spin-down 95 -> 76 ms over 80..440 g, from `points` operating points; `slower` scales them.
inline tc::ModelV2 withDynamics(tc::ModelV2 model, uint8_t points = 5, double slower = 1.0) {
  tc::MotorDynamics& d = model.dynamics;
  d.points = points;
  d.lo_dg = 800;
  d.hi_dg = 4400;
  d.up_lo_01ms = static_cast<uint16_t>(std::lround(920 * slower));
  d.up_hi_01ms = static_cast<uint16_t>(std::lround(740 * slower));
  d.down_lo_01ms = static_cast<uint16_t>(std::lround(950 * slower));
  d.down_hi_01ms = static_cast<uint16_t>(std::lround(760 * slower));
  return model;
}

inline bool sameCalibration(const tc::MotorCalibration& a, const tc::MotorCalibration& b) {
  if (a.first.start_mv != b.first.start_mv || a.second.start_mv != b.second.start_mv ||
      a.first.maxGrams() != b.first.maxGrams() || a.second.maxGrams() != b.second.maxGrams() ||
      a.sag.base_pwm_us != b.sag.base_pwm_us)
    return false;
  for (uint16_t g = 0; g <= tc::kCurveGrams; ++g)
    if (a.first.pwmForGrams(g) != b.first.pwmForGrams(g) || a.second.pwmForGrams(g) != b.second.pwmForGrams(g))
      return false;
  for (uint8_t i = 0; i < tc::kSagBins; ++i)
    if (a.sag.offset_mv[i] != b.sag.offset_mv[i]) return false;
  return true;
}

inline bool sameModel(const tc::ModelV2& a, const tc::ModelV2& b) {
  if (a.start_q4_us != b.start_q4_us || a.step_dg != b.step_dg || a.knots != b.knots ||
      a.fine_knots != b.fine_knots || a.coarse_step_dg != b.coarse_step_dg || a.flags != b.flags ||
      a.rest_mv != b.rest_mv || a.second_mv != b.second_mv || a.dynamics != b.dynamics)
    return false;
  for (uint8_t k = 0; k < tc::kV2MaxKnots; ++k)
    if (a.drive_512usmv[k] != b.drive_512usmv[k] || a.sag_10mv[k] != b.sag_10mv[k]) return false;
  return true;
}

}  // namespace tc_test

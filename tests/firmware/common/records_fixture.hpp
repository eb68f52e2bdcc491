// Calibration records for the firmware host tests, built the way gather_store builds them: a
// plant whose thrust follows the effective motor voltage, its sweeps turned into v1 records
// (tc::CurveBuilder + tc::writeRecord) or fitted into v2 records (tc::ModelV2Fitter +
// tc::writeModelV2), written into the fake EEPROM; and small text helpers. Shared by the
// read_run and fly tests (both fly the force API, firmware/common/force_actuators.hpp).
#pragma once
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "hal/fake.hpp"
#include "hal/hal.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/record_v2.hpp"

namespace records_test {

// Battery readings the tests use, as ADC counts on A1 (thesis divider, 15.638 V full scale).
constexpr uint16_t kCountsV1 = 740;  // first curve's start voltage (LiPo)
constexpr uint16_t kCountsV2 = 820;  // second curve's start voltage

inline uint16_t mvFromCounts(uint16_t counts) { return tc::BatteryMonitor().millivoltsFromCounts(counts); }

// Plant: thrust follows the effective motor voltage duty * V (docs/model_v2.md), quadratically:
//   F = k * ((pwm - 1080 us) / 1000 us * V)^2,  k in g/V^2 differs per motor.
inline double plantForceG(double k, uint16_t pwm_us, uint16_t vbat_mv) {
  if (pwm_us <= 1080) return 0.0;
  const double x = (pwm_us - 1080) / 1000.0 * (vbat_mv / 1000.0);
  return k * x * x;
}

// One sweep of the plant at a fixed battery voltage, turned into a force curve.
inline void buildCurve(tc::ForceCurveBase& curve, double k, uint16_t vbat_mv) {
  auto builder = std::make_unique<tc::CurveBuilder<128>>();
  for (uint16_t pwm = 1000; pwm <= 2000; pwm += 10) {
    builder->add(pwm, static_cast<int16_t>(std::lround(plantForceG(k, pwm, vbat_mv) * 10.0)));
  }
  const tc::BuildReport report = builder->build(curve);
  ASSERT_EQ(report.status, tc::BuildStatus::kOk);
  curve.start_mv = vbat_mv;
}

struct MotorSpec {
  double k = 13.5;              // plant constant, g/V^2
  bool second_curve = true;     // false: first curve only
  int16_t sag_mv_per_bin = 0;   // sag offset of bin i = i * this
};

inline std::unique_ptr<tc::MotorCalibration> makeCalibration(const MotorSpec& spec) {
  auto cal = std::make_unique<tc::MotorCalibration>();
  buildCurve(cal->first, spec.k, mvFromCounts(kCountsV1));
  if (spec.second_curve) buildCurve(cal->second, spec.k, mvFromCounts(kCountsV2));
  cal->sag.base_pwm_us = 1000;
  for (uint8_t i = 0; i < tc::kSagBins; ++i) {
    cal->sag.offset_mv[i] = static_cast<int16_t>(i * spec.sag_mv_per_bin);
  }
  return cal;
}

inline void storeMotor(uint8_t slot, const MotorSpec& spec) {
  auto cal = makeCalibration(spec);
  tc::writeRecord<hal::Eeprom>(slot, *cal);
}

// What the EEPROM round trip gives the firmware (the sag table is stored in 10 mV units).
inline std::unique_ptr<tc::MotorCalibration> storedCalibration(uint8_t slot) {
  auto cal = std::make_unique<tc::MotorCalibration>();
  EXPECT_EQ(tc::readRecord<hal::Eeprom>(slot, *cal), tc::DecodeStatus::kOk);
  return cal;
}

// Thesis option 2.1 written out independently in floating point.
// Model v2 of a plant motor, fitted on the board's way (tc::ModelV2Fitter) from one sweep
// 1000..2000 us in 10 us steps at `vbat_mv` resting, forces recorded in decigrams. With
// sag_mv_per_100g the monitor reads that much lower per 100 g of thrust (the bench sag).
inline tc::ModelV2 fitV2Model(double k, uint16_t vbat_mv, double sag_mv_per_100g = 0.0) {
  auto fitter = std::make_unique<tc::ModelV2Fitter<128>>();
  for (uint16_t pwm = 1000; pwm <= 2000; pwm += 10) {
    double force_g = plantForceG(k, pwm, vbat_mv);
    uint16_t read_mv = vbat_mv;
    for (int i = 0; i < 20; ++i) {  // operating point: the sag lowers the force a little
      read_mv = static_cast<uint16_t>(std::lround(vbat_mv - sag_mv_per_100g * force_g / 100.0));
      force_g = plantForceG(k, pwm, read_mv);
    }
    fitter->add(pwm, static_cast<int16_t>(std::lround(force_g * 10.0)), read_mv);
  }
  tc::ModelV2 model;
  const tc::FitV2Report report = fitter->fit(model);
  EXPECT_EQ(report.status, tc::FitV2Status::kOk) << tc::fitV2StatusText(report.status);
  return model;
}

// Fits and stores a v2 record (the power-fail-safe writer: the next copy, sequence + 1).
inline tc::ModelV2 storeV2Motor(uint8_t slot, double k, uint16_t vbat_mv,
                                double sag_mv_per_100g = 0.0) {
  const tc::ModelV2 model = fitV2Model(k, vbat_mv, sag_mv_per_100g);
  const tc::RecordV2Write write = tc::writeModelV2<hal::Eeprom>(slot, model);
  EXPECT_EQ(write.status, tc::WriteV2Status::kWritten) << tc::writeV2StatusText(write.status);
  return model;
}

// What read_run loads from a v2 slot (the newest valid copy).
inline tc::ModelV2 storedV2Model(uint8_t slot) {
  tc::ModelV2 model;
  EXPECT_EQ(tc::readModelV2<hal::Eeprom>(slot, model).status, tc::DecodeStatus::kOk);
  return model;
}

inline double option21PwmUs(const tc::MotorCalibration& cal, uint16_t force_g, uint16_t vbat_mv) {
  const double c1 = cal.first.pwmForGrams(force_g);
  const double c2 = cal.second.pwmForGrams(force_g);
  const double v1 = cal.first.start_mv;
  const double v2 = cal.second.start_mv;
  return c1 + (vbat_mv - v1) * (c2 - c1) / (v2 - v1);
}

inline std::string volts(uint16_t mv) {
  char text[16];
  std::snprintf(text, sizeof text, "%u.%03u", mv / 1000u, mv % 1000u);
  return text;
}

inline std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::string line;
  std::istringstream in(text);
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    out.push_back(line);
  }
  return out;
}

inline bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace records_test

// The bench's calibrated aircraft (bench/records.hpp).
#include "bench/records.hpp"

#ifdef THRUSTCAL_BENCH_HAVE_SIM
#include <fmt/format.h>

#include <memory>
#include <stdexcept>

#include "bench/accuracy.hpp"  // plantDynamics
#include "bench/sweeps.hpp"
#include "calibration_runs.hpp"
#include "sim/board.hpp"
#include "sim/scenarios.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/eeprom_image.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/record_v2.hpp"

namespace bench {

namespace {

// store 1 / store 2: the thesis curve of a sweep and its sag offsets (the first sweep's are kept).
void addThesisCurve(const Sweep& sweep, int pwm_min_us, bool first, tc::MotorCalibration& cal, size_t motor) {
  auto builder = std::make_unique<tc::CurveBuilder<161>>();
  tc::SagBuilder sag;
  sag.reset(static_cast<uint16_t>(pwm_min_us));
  for (const SweepPoint& p : sweep.points) {
    builder->add(p.pwm_us, p.force_dg);
    sag.add(p.pwm_us, p.vbat_mv);
  }
  tc::ThesisCurve& curve = first ? cal.first : cal.second;
  if (builder->build(curve).status != tc::BuildStatus::kOk)
    throw std::runtime_error(fmt::format("bench records: no thesis curve for motor {}", motor));
  uint16_t start_mv = 0;
  tc::SagTable second;
  sag.build(first ? cal.sag : second, start_mv);
  curve.start_mv = start_mv;
}

void writeV1(const Sweep& lipo, const Sweep& supply, int pwm_min_us, size_t motor,
             std::vector<uint8_t>& image) {
  auto cal = std::make_unique<tc::MotorCalibration>();
  addThesisCurve(lipo, pwm_min_us, true, *cal, motor);
  addThesisCurve(supply, pwm_min_us, false, *cal, motor);
  const tc::EepromImage::Use use(image);
  tc::writeRecord<tc::EepromImage>(static_cast<uint8_t>(motor), *cal);
}

// store v2 after each sweep: fit on the LiPo's, refine with the supply's.
void writeV2(const Sweep& lipo, const Sweep& supply, size_t motor, std::vector<uint8_t>& image,
             const tc::MotorDynamics& dynamics = tc::MotorDynamics()) {
  auto fitter = std::make_unique<tc::ModelV2Fitter<161>>();
  tc::ModelV2 model;
  for (const SweepPoint& p : lipo.points) fitter->add(p.pwm_us, p.force_dg, p.vbat_mv);
  if (fitter->fit(model).status != tc::FitV2Status::kOk)
    throw std::runtime_error(fmt::format("bench records: model v2 fit failed for motor {}", motor));
  fitter->reset();
  for (const SweepPoint& p : supply.points) fitter->add(p.pwm_us, p.force_dg, p.vbat_mv);
  fitter->refine(model);
  model.dynamics = dynamics;
  const tc::EepromImage::Use use(image);
  if (tc::writeModelV2<tc::EepromImage>(static_cast<uint8_t>(motor), model).status !=
      tc::WriteV2Status::kWritten)
    throw std::runtime_error(fmt::format("bench records: model v2 of motor {} not written", motor));
}

}  // namespace

const BenchRecords& benchRecords() {
  static BenchRecords r;
  if (!r.v1.empty()) return r;
  r.v1.assign(sim::kEepromBytes, 0xFF);
  r.v2.assign(sim::kEepromBytes, 0xFF);
  r.v2_dyn.assign(sim::kEepromBytes, 0xFF);
  std::vector<SweepPoint> all;  // ArduPilot: one fit for every motor
  for (size_t i = 0; i < 4; ++i) {
    r.motors[i] = sim::motorForSeed(kPreset, kSeeds[i], kVariation);
    SweepSpec spec;
    spec.pwm_min_us = 1040;
    spec.settle_ms = 600;
    spec.noise_seed = kSeeds[i];
    const Sweep lipo = simulateSweep(r.motors[i], lipoAt(12.4), spec);
    const Sweep supply = simulateSweep(r.motors[i], plant::BatteryParams::benchSupply(10.5, 6.32), spec);
    writeV1(lipo, supply, spec.pwm_min_us, i, r.v1);
    writeV2(lipo, supply, i, r.v2);
    writeV2(lipo, supply, i, r.v2_dyn, plantDynamics(r.motors[i]));
    all.insert(all.end(), lipo.points.begin(), lipo.points.end());
    all.insert(all.end(), supply.points.begin(), supply.points.end());
  }
  r.ardupilot = fitExpo(all);
  return r;
}

}  // namespace bench

#endif  // THRUSTCAL_BENCH_HAVE_SIM

// Identifying dynamics from step logs (gather_store's `dyn`, `dyn cell`; the bench's simulated
// sessions): the bench's own response from a weight lifted off the plate, each motor's time
// constant from force steps with the bench's response taken out, and the law that joins the
// operating points (thrustcal/dynamics.hpp).
//
// A step log is what gather_store records at the load cell's full ADC rate: the mean force of
// every block of kDynBlockConversions conversions (about 1.7 ms), with the instant the new
// pulse reached the ESC. Float arithmetic: this runs once per step on the bench, never in
// flight. Each fit says how it fails (ok false, with the reason in `why`).
#pragma once
#include <stdint.h>

#include "thrustcal/dynamics.hpp"

namespace tc {

// ADC conversions per block of a step log: 16 at the ATmega2560's 104 us per conversion.
constexpr uint8_t kDynBlockConversions = 16;

// ADC conversions of the battery monitor per block (after the load cell's), and blocks per
// battery value kept: the bus voltage at the ESC during the step (its sag under the current
// surge slows the motor on the bench; the fit takes it out).
constexpr uint8_t kDynBlocksPerVbat = 4;

struct StepLog {
  const int16_t* force_dg = nullptr;  // one mean per block, decigrams, thrust positive
  uint16_t blocks = 0;
  float block_s = 0.0f;  // block k spans [k, k + 1) * block_s from the log's start
  float step_s = 0.0f;   // when the new pulse took effect (the ESC's edge), from the log's start
  // Optional (null: the drive is taken as a clean step): the bus voltage, one mean per
  // kDynBlocksPerVbat blocks, millivolts; with the pulses before and after the step and the
  // ESC's start threshold, the motor's input is the drive (pulse - start) * V, as measured.
  const uint16_t* vbat_mv = nullptr;
  uint16_t from_us = 0, to_us = 0;
  float start_us = 0.0f;
  // Called every 16 samples of every pass over the log (null: none): a fit takes a few hundred
  // passes, ~1 s on the ATmega2560, and gather_store kicks its watchdog from here. A sample of
  // the motor's pass costs ~8,000 cycles on the AVR (the bench's filter stages in float): 64
  // samples between calls were 32.7 ms, half the watchdog's time-out (tests/hil_safety,
  // WatchdogHeadroom); 16 are ~8 ms.
  void (*yield)() = nullptr;
};

enum class StepFitWhy : uint8_t {
  kOk = 0,
  kTooShort,      // fewer than 40 blocks, or the step too near an end of the log
  kNoStep,        // the force moved by less than 8 times the fit's residual (or 1 g)
  kAtBound,       // the time constant ran to the search's bound: not a first-order response
  kNoBench,       // the bench response is not identified (`dyn cell` first)
};
// In flash on the AVR (TC_FLASH_TEXT).
const char* stepFitWhyText(StepFitWhy why);

struct MotorStepFit {
  StepFitWhy why = StepFitWhy::kTooShort;
  float tau_s = 0.0f;   // the motor's own time constant (its speed), the bench's lag taken out
  float from_g = 0.0f;  // force before the step
  float to_g = 0.0f;    // force it settles at
  float rms_g = 0.0f;   // residual of the fit, per block
  bool ok() const { return why == StepFitWhy::kOk; }
};

// The motor's speed is a first-order lag of tau from the step on (thrust = speed squared), seen
// through `bench`; the force before and after and tau are fitted (least squares over the log).
// `stride` blocks are averaged into one sample first (the fit's cost falls by that factor).
MotorStepFit fitMotorStep(const StepLog& log, const BenchResponse& bench, uint8_t stride = 1);

struct BenchStepFit {
  StepFitWhy why = StepFitWhy::kTooShort;
  uint8_t stages = 0;
  float tau_s = 0.0f;
  float step_s = 0.0f;  // the fitted instant of the step
  float from_g = 0.0f, to_g = 0.0f;
  float rms_g = 0.0f;
  bool ok() const { return why == StepFitWhy::kOk; }
  BenchResponse response() const;  // rounded to the stored units
};

// A force step with no motor in it (a weight lifted off at once) through 1..4 equal stages:
// the number of stages, their time constant and the step's instant are fitted; log.step_s is
// ignored.
BenchStepFit fitBenchStep(const StepLog& log);

// Joins the operating points into MotorDynamics: 1/tau = a + b sqrt(F) per direction by least
// squares, stored as its values at the lightest and heaviest point. build() fails (false,
// `out` cleared) with no point, or when a time constant lands outside the record's range.
class DynamicsLawFit {
 public:
  void reset() { count_ = 0; }
  // False (dropped) when full or a value is not positive.
  bool add(float force_g, float tau_up_s, float tau_down_s);
  uint8_t size() const { return count_; }
  bool build(MotorDynamics& out) const;

 private:
  float force_g_[kDynMaxPoints];
  float tau_up_s_[kDynMaxPoints];
  float tau_down_s_[kDynMaxPoints];
  uint8_t count_ = 0;
};

}  // namespace tc

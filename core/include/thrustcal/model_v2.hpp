// Force model v2: thrust follows the effective motor voltage, not the PWM.
//
// Why: a DC motor turning a propeller settles at a speed set by the mean voltage across its
// windings, duty * V_bus, so PWM-per-volt is a hyperbola and the thesis's option 2.1 (linear in
// voltage between two curves) drifts away from its two calibration voltages. v2 models that:
//
//   drive = (pwm - start) * V_bus        [us*mV; stored in units of 512 us*mV]
//   force = curve(drive)                 [monotone, one curve for every voltage]
//
// Per motor (ModelV2): the ESC's start threshold (1/16 us); a monotone force curve in drive,
// up to 32 knots placed by FORCE (the run time goes force -> PWM: the knot index is a multiply
// by a precomputed reciprocal, no search, no division) in a fine run up to a quarter of the
// largest force and a coarse run above (drive ~ force^0.5 bends hardest at the low end); the
// bench sag per knot and the resting voltage, to predict the bus voltage at a commanded
// operating point that differs from the present one.
//
// Run time (forceToPwmV2; read_run flies its motors with one tc::V2Frame::fly,
// model_v2_runtime.hpp): no float and no division per frame or per motor; 16x16->32
// multiplies and byte-aligned shifts only. headroomDg / forceForPwmDg (status, not per frame)
// divide once each.
//
// Fitting on the board (ModelV2Fitter, gather_store, once per sweep; 32/32 divisions allowed):
// the start threshold from the sweep's shape without assuming an exponent (for any power law
// the PWMs at F, 2F, 4F give s = p1 - (p2 - p1)^2 / (p3 - 2 p2 + p1); the median over triples
// at the low end), and a second sweep at another voltage measures it exactly (refine():
// (pA - s) VA = (pB - s) VB for every force).
// docs/model_v2.md explains the choices and gives their measured cost and accuracy.
#pragma once
#include <stdint.h>

#include "thrustcal/dynamics.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/record_limits.hpp"

namespace tc {

constexpr uint8_t kV2MaxKnots = 32;
constexpr uint16_t kDriveUnitUsMv = 512;   // one stored drive unit = 512 us*mV
constexpr uint8_t kV2SagUnitMv = 10;       // sag table unit
constexpr uint16_t kV2MinStepDg = 66;      // 2^22 / step must fit 16 bits (Q22 reciprocal)
constexpr uint16_t kV2MinStepSmallDg = 2;  // 2^16 / step must fit 16 bits (Q16, one run only)
// Reciprocal scale: recip_q27 = 2^27 / mV fits 16 bits down to kPackMinMv (3.0 V, one cell).
constexpr uint32_t kRecipOne = 1ul << 27;
// Bus / monitor readings model v2 accepts (the filter ignores others, a model whose resting
// reading lies outside does not finalize): 1S..6S packs.
constexpr uint16_t kV2SaneMinMv = kPackMinMv;
constexpr uint16_t kV2SaneMaxMv = kPackMaxMv;
inline bool isSaneV2Mv(uint16_t mv) { return mv >= kV2SaneMinMv && mv <= kV2SaneMaxMv; }
// Start thresholds a model may hold (ModelV2::finalize, the fitter's estimates), 1/16 us.
constexpr uint16_t kV2StartMinQ4Us = 800u * 16u;
constexpr uint16_t kV2StartMaxQ4Us = 1800u * 16u;

struct ModelV2 {
  // Stored fields (record_v2.hpp serializes exactly these). Field order: everything the
  // per-frame path reads lies within 63 bytes of the start (the AVR's ldd reach), the
  // tables last.
  uint16_t start_q4_us = 0;   // ESC start threshold, 1/16 us; 0 = no model
  uint16_t step_dg = 0;       // force between the fine knots, decigrams
  uint8_t knots = 0;          // knots used, 2..32
  uint8_t fine_knots = 0;     // knots 0..fine_knots-1 at (k + 1) * step_dg; 1..knots
  uint16_t coarse_step_dg = 0;  // force between the knots above; 0 when fine_knots == knots
  uint8_t flags = 0;          // kV2Refined when a second sweep set the start threshold
  uint16_t rest_mv = 0;       // monitor reading at zero force in the (first) sweep
  uint16_t second_mv = 0;     // resting reading of the refining sweep; 0 = single sweep

  // Derived by finalize() (not stored).
  uint16_t inv_step_q22 = 0;    // round(2^22 / step_dg), < 2^16 as step >= kV2MinStepDg;
                                // round(2^16 / step_dg) when q16_inverse
  uint16_t inv_coarse_q22 = 0;  // round(2^22 / coarse_step_dg), 0 without coarse knots
  uint16_t split_dg = 0;        // fine_knots * step_dg: where the coarse knots begin
  uint16_t rest_recip_q27 = 0;  // 2^27 / rest_mv: the voltage used when the bus reading is bad
  uint16_t max_force_dg = 0;    // force of the last knot
  uint32_t start_q17_us = 0;    // start threshold in 2^-17 us
  uint8_t q16_inverse = 0;      // 1: step_dg < kV2MinStepDg, inv_step_q22 holds 2^16 / step

  // Stored tables.
  uint16_t drive_512usmv[kV2MaxKnots] = {};  // drive at each knot, non-decreasing, > 0
  uint8_t sag_10mv[kV2MaxKnots] = {};        // rest_mv minus the reading at each knot

  // The motor's speed lag (gather_store's `dyn`; none until measured): stored with the model,
  // in the same copy under its CRC (record_v2.hpp), so it survives every store as the model does.
  MotorDynamics dynamics;

  bool isPresent() const { return start_q4_us != 0 && knots != 0; }
  uint16_t maxForceDg() const { return max_force_dg; }
  // Force of knot k (0-based), decigrams.
  uint16_t knotForceDg(uint8_t k) const {
    return k < fine_knots ? static_cast<uint16_t>((k + 1) * step_dg)
                          : static_cast<uint16_t>(split_dg + (k + 1 - fine_knots) * coarse_step_dg);
  }
  // Checks the stored fields against what the fixed-point maths needs and computes the
  // derived ones. False (model cleared) when a field is out of range: start outside
  // 800..1800 us, a step below kV2MinStepDg with coarse knots or below kV2MinStepSmallDg in
  // one run (coarse: at least kV2MinStepDg, or 0 without coarse knots), knots outside 2..32,
  // fine_knots outside 1..knots, rest_mv / second_mv outside kPackMinMv..kPackMaxMv
  // (second_mv may be 0), drive not increasing (a knot lower than the one before, or the
  // first knot 0), dynamics present but not valid (MotorDynamics::isValid). Whether the model
  // is physically right is checkModelV2's question (thrustcal/plausibility.hpp).
  bool finalize();
  void clear();
};

// Flags. kV2HasDynamics is the record's (set when the model has dynamics, record_v2.hpp), never
// a ModelV2's: parsing clears it from `flags` and fills `dynamics`.
enum : uint8_t { kV2Refined = 1u << 0, kV2HasDynamics = 1u << 1 };

// Battery reading filter: first-order IIR, y += (x - y) / 2^shift per frame (default 1/8),
// exact in steady state (`rem` keeps the fraction below 1 mV), plus the reciprocal of y for
// division-free PWM. Samples outside kPackMinMv..kPackMaxMv (3.0..26.0 V: 1S..6S) are ignored
// (the last good value stays)
// and counted; until the first good sample isValid() is false.
struct BusVoltageFilter {
  uint16_t mv = 0;           // filtered millivolts (floor of y)
  uint8_t rem = 0;           // fraction of y below 1 mV, in 1/256 mV
  uint8_t shift = 3;         // alpha = 1 / 2^shift, 0..6
  uint16_t recip_q27 = 0;    // 2^27 / mv (within 1 LSB after the first update in steady state)
  uint8_t rejected = 0;      // samples ignored as insane (saturates at 255)
  uint8_t reseeds = 0;       // divisions spent on big jumps (saturates at 255)

  bool isValid() const { return mv != 0; }
  // Starts at `mv_now` (one division). An insane value leaves the filter invalid.
  void reset(uint16_t mv_now);
  // One frame: 16-bit arithmetic for the IIR, and only when the filtered millivolts change,
  // one Newton step (two 16x16 multiplications). First good sample after an invalid state
  // resets to it.
  void update(uint16_t sample_mv);
};

// Force (decigrams) -> PWM at the filtered bus voltage, fixed point. Defined behaviour:
//   no model                          -> pwm_min, kNotCalibrated
//   force 0                           -> pwm_min, kStopped
//   bus filter not valid              -> uses the model's rest_mv, kVoltageInvalid
//   force above the curve's last knot -> PWM at the last knot, kSaturated
//   PWM above pwm_max (not enough voltage for that force) -> pwm_max, kSaturated
//   PWM below pwm_min                 -> pwm_min, kClamped
ForcePwmResult forceToPwmV2(const ModelV2& model, uint16_t force_dg, const BusVoltageFilter& bus,
                            const ForcePwmLimits& limits = ForcePwmLimits());
// Same, but predicts the bus voltage at the commanded force from the bench sag:
// V_cmd = V_now + sag(force_now_dg) - sag(force_dg), force_now_dg being what this motor
// produces now (its last command). Use it on command steps; in steady state it equals the
// plain call.
ForcePwmResult forceToPwmV2(const ModelV2& model, uint16_t force_dg, const BusVoltageFilter& bus,
                            uint16_t force_now_dg, const ForcePwmLimits& limits = ForcePwmLimits());
inline ForcePwmResult forceGramsToPwmV2(const ModelV2& model, uint16_t force_g,
                                        const BusVoltageFilter& bus,
                                        const ForcePwmLimits& limits = ForcePwmLimits()) {
  return forceToPwmV2(model, force_g > 6553 ? 65535u : static_cast<uint16_t>(force_g * 10u), bus,
                      limits);
}

// The model's force (decigrams) at a PWM and bus voltage: inverse of forceToPwmV2 (one
// division). 0 below the start threshold or without a model; capped at maxForceDg().
uint16_t forceForPwmDg(const ModelV2& model, uint16_t pwm_us, uint16_t vbus_mv);
// Headroom for the status command: the largest force reachable at `vbus_mv` with the ESC at
// limits.pwm_max_us (capped at the curve's end). 0 without a model.
uint16_t headroomDg(const ModelV2& model, uint16_t vbus_mv,
                    const ForcePwmLimits& limits = ForcePwmLimits());

// ---- Fitting -------------------------------------------------------------------------------

struct SweepPointV2 {
  uint16_t pwm_us;
  int16_t force_dg;  // thrust positive
  uint16_t vbat_mv;  // monitor reading at that step, as recorded (not sag-compensated)
};

enum class FitV2Status : uint8_t {
  kOk = 0,
  kTooFewSamples,    // fewer than 8 samples
  kNoForce,          // the sweep never reached kRecordMinForceG (5 g): motor not spinning?
  kBadVoltage,       // a sample's vbat_mv outside kPackMinMv..kPackMaxMv: monitor not connected
  kStartNotFound,    // no usable force triple / voltage pair: sweep too coarse or too short
  kVoltagesTooClose, // refine: the two sweeps' resting voltages differ by < 500 mV
  kNoModel,          // refine: the model to refine is absent
};

const char* fitV2StatusText(FitV2Status status);

struct FitV2Report {
  FitV2Status status = FitV2Status::kTooFewSamples;
  uint16_t samples_used = 0;
  uint16_t violations = 0;     // samples the monotone fit moved
  int16_t max_force_dg = 0;    // largest fitted force of this sweep
  uint16_t start_q4_us = 0;    // start threshold found
  uint8_t estimates = 0;       // triples (fit) or knots (refine) behind the median
  uint16_t rest_mv = 0;        // this sweep's resting reading
};

class ModelV2FitterBase {
 public:
  void reset() { count_ = 0; }
  // False when full (the sample is dropped).
  bool add(uint16_t pwm_us, int16_t force_dg, uint16_t vbat_mv);
  uint16_t size() const { return count_; }
  uint16_t capacity() const { return capacity_; }
  const SweepPointV2& sample(uint16_t i) const { return samples_[i]; }
  // Fits `out` from the samples (one sweep). On any status but kOk `out` is cleared.
  // The samples are reordered and smoothed in place.
  FitV2Report fit(ModelV2& out);
  // Treats the samples as a second sweep at another voltage and refines `model` (start
  // threshold from both, knots averaged). On failure `model` is left unchanged.
  FitV2Report refine(ModelV2& model);

 protected:
  ModelV2FitterBase(SweepPointV2* samples, uint16_t* weights, uint16_t capacity)
      : samples_(samples), weights_(weights), capacity_(capacity) {}

 private:
  FitV2Report prepare();  // sort, check, monotone fit, rest voltage
  SweepPointV2* samples_;
  uint16_t* weights_;     // monotone-fit work space
  uint16_t capacity_;
  uint16_t count_ = 0;
};

template <uint16_t MaxSamples>
class ModelV2Fitter : public ModelV2FitterBase {
  static_assert(MaxSamples >= 8 && MaxSamples <= 512, "8..512 samples");

 public:
  ModelV2Fitter() : ModelV2FitterBase(samples_storage_, weight_storage_, MaxSamples) {}
  ModelV2Fitter(const ModelV2Fitter&) = delete;
  ModelV2Fitter& operator=(const ModelV2Fitter&) = delete;

 private:
  SweepPointV2 samples_storage_[MaxSamples];
  uint16_t weight_storage_[MaxSamples];
};

}  // namespace tc

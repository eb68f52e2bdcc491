// Plausibility of calibration records: "never fly a record that cannot be right".
//
// A record whose CRC is right may still be wrong: written by a buggy tool, fitted from a bad
// sweep, or garbage that happens to pass (an all-0xFFFF drive table, a thesis curve that puts
// 1 g at 2500 us). The decoders (readRecord for v1, parseModelV2 for v2) run these checks
// after the CRC and refuse the record as DecodeStatus::kBadContent with the first rule that
// failed; the firmware prints it in gather_store's `show` and read_run's start-up report and
// `status`, and the writers refuse to store a model that fails them.
//
// The rules and their limits (thrustcal/record_limits.hpp), in the order they are checked:
//   v1 (per curve; curve 2 only when present):
//     kNoCurve      the first curve is absent
//     kMalformed    a real step after the end marker, a PWM beyond 65535 us
//     kVoltage      start voltage outside kPackMinMv .. min(kPackMaxMv, monitor full scale)
//     kPwmRange     PWM at 1 g or at the heaviest gram outside the ESC's 1000..2000 us
//     kForceSpan    the heaviest gram below kRecordMinForceG
//     kFlat         PWM span 1 g -> heaviest gram below max(5 us, grams / 10)
//     kSagBase      sag table base PWM outside the ESC range
//     kMalformed    sag offset of bin 0 not 0
//     kSag          a sag offset below -kMaxSagRiseMv or above kMaxSagPercent of the start voltage
//   v2:
//     kMalformed    knot count, fine knots or knot steps outside the layout
//     kStartRange   ESC start threshold outside kStartMinUs..kStartMaxUs
//     kVoltage      resting voltage (and the refining sweep's) outside the pack/monitor range
//     kFlat         first knot at drive 0
//     kNotMonotone  a knot's drive below the one before
//     kFlat         drive grows by less than kMinDriveGrowthPct from the first knot to the last
//     kForceSpan    largest force outside kRecordMinForceG..kRecordMaxForceG
//     kSag          sag at a knot above kMaxSagPercent of the resting voltage
//     kPwmRange     PWM at the last knot, at the best voltage the record saw, above the ESC's
//                   maximum (+ kPwmToleranceUs)
//     kMalformed    motor dynamics present with a point count outside 1..kDynMaxPoints, the
//                   lightest point 0 or above the heaviest (thrustcal/dynamics.hpp)
//     kDynamics     a time constant of the dynamics outside kDynTauMin01ms..kDynTauMax01ms, or
//                   the two ends of one point differing
#pragma once
#include <stdint.h>

#include "thrustcal/flash_text.hpp"
#include "thrustcal/record_limits.hpp"

namespace tc {

struct MotorCalibration;
struct ModelV2;
struct MotorDynamics;
class ForceCurveBase;

enum class Implausible : uint8_t {
  kNone = 0,
  kMalformed,
  kNoCurve,
  kVoltage,
  kPwmRange,
  kFlat,
  kNotMonotone,
  kForceSpan,
  kStartRange,
  kSagBase,
  kSag,
  kDynamics,
};
constexpr Implausible kLastImplausible = Implausible::kDynamics;

// Unit of a Plausibility's value and limits.
enum class PlausibilityUnit : uint8_t { kNone = 0, kUs, kMv, kDg, kG, kPercent, kTenthMs };

// The first rule a record broke, where, the offending value and the allowed range.
struct Plausibility {
  Implausible rule = Implausible::kNone;
  uint8_t curve = 0;   // v1: 1 or 2 (0: the record); v2: 0
  int8_t index = -1;   // v1: sag bin; v2: knot (0-based); -1: none
  PlausibilityUnit unit = PlausibilityUnit::kNone;
  int32_t value = 0;
  int32_t lo = 0;      // allowed range (inclusive)
  int32_t hi = 0;

  bool ok() const { return rule == Implausible::kNone; }
};

// Short text of a rule ("pulse outside the ESC range"). On the AVR the pointer is in flash
// (TC_FLASH_TEXT): print it with hal::Uart::printP. Never null.
const char* implausibleText(Implausible rule);

// v1: checks a decoded thesis record and finalizes its curves (an absent second curve is
// cleared, whatever its bytes). Returns the first broken rule; ok() when it can be right.
Plausibility checkCalibration(MotorCalibration& cal, const RecordLimits& limits = RecordLimits());
// v2: checks the stored fields of a model (finalize() need not have run).
Plausibility checkModelV2(const ModelV2& model, const RecordLimits& limits = RecordLimits());
// A motor's dynamics (thrustcal/dynamics.hpp; checkModelV2 runs it on a model that has them).
Plausibility checkDynamics(const MotorDynamics& dynamics);

// Prints "TEXT (WHERE: VALUE UNIT; allowed LO..HI UNIT)" (or "; at least LO UNIT" when the
// rule has no upper limit) through an output with
//   void flash(const char* text);     // a TC_FLASH_TEXT string
//   void fixed(int32_t value, uint8_t decimals);
// (firmware: hal::Uart; host: a std::string). Voltages print in V, decigrams in g.
template <class Out>
void printPlausibility(const Plausibility& p, Out& out) {
  out.flash(implausibleText(p.rule));
  const bool where = p.curve != 0 || p.index >= 0;
  if (!where && p.unit == PlausibilityUnit::kNone) return;
  out.flash(TC_FLASH_TEXT(" ("));
  if (p.curve) {
    out.flash(TC_FLASH_TEXT("curve "));
    out.fixed(p.curve, 0);
    if (p.index >= 0) {
      out.flash(TC_FLASH_TEXT(" sag bin "));
      out.fixed(p.index, 0);
    }
  } else if (p.index >= 0) {
    out.flash(TC_FLASH_TEXT("knot "));
    out.fixed(p.index + 1, 0);
  }
  if (p.unit != PlausibilityUnit::kNone) {
    if (where) out.flash(TC_FLASH_TEXT(": "));
    uint8_t decimals = 0;
    const char* unit = TC_FLASH_TEXT(" us");
    switch (p.unit) {
      case PlausibilityUnit::kMv: decimals = 3; unit = TC_FLASH_TEXT(" V"); break;
      case PlausibilityUnit::kDg: decimals = 1; unit = TC_FLASH_TEXT(" g"); break;
      case PlausibilityUnit::kG: unit = TC_FLASH_TEXT(" g"); break;
      case PlausibilityUnit::kPercent: unit = TC_FLASH_TEXT(" %"); break;
      case PlausibilityUnit::kTenthMs: decimals = 1; unit = TC_FLASH_TEXT(" ms"); break;
      default: break;
    }
    out.fixed(p.value, decimals);
    out.flash(unit);
    if (p.hi < p.lo) {
      out.flash(TC_FLASH_TEXT("; at least "));
    } else {
      out.flash(TC_FLASH_TEXT("; allowed "));
    }
    out.fixed(p.lo, decimals);
    if (p.hi >= p.lo) {
      out.flash(TC_FLASH_TEXT(".."));
      out.fixed(p.hi, decimals);
    }
    out.flash(unit);
  }
  out.flash(TC_FLASH_TEXT(")"));
}

}  // namespace tc

// Plausibility rules of calibration records (see plausibility.hpp for the list).
#include "thrustcal/plausibility.hpp"

#include "thrustcal/model_v2.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace tc {

const char* implausibleText(Implausible rule) {
  switch (rule) {
    case Implausible::kNone: return TC_FLASH_TEXT("plausible");
    case Implausible::kMalformed: return TC_FLASH_TEXT("malformed record (fields outside the layout)");
    case Implausible::kNoCurve: return TC_FLASH_TEXT("no first curve");
    case Implausible::kVoltage: return TC_FLASH_TEXT("voltage outside the pack and monitor range");
    case Implausible::kPwmRange: return TC_FLASH_TEXT("pulse outside the ESC range");
    case Implausible::kFlat: return TC_FLASH_TEXT("flat curve (force without drive)");
    case Implausible::kNotMonotone: return TC_FLASH_TEXT("curve not monotone (force falls as drive rises)");
    case Implausible::kForceSpan: return TC_FLASH_TEXT("largest force out of range");
    case Implausible::kStartRange: return TC_FLASH_TEXT("ESC start threshold out of range");
    case Implausible::kSagBase: return TC_FLASH_TEXT("sag table base pulse outside the ESC range");
    case Implausible::kSag: return TC_FLASH_TEXT("battery sag out of bounds");
    case Implausible::kDynamics: return TC_FLASH_TEXT("motor dynamics out of range");
  }
  return TC_FLASH_TEXT("unknown rule");
}

namespace {

// Not inlined: one call per rule keeps the AVR images small.
__attribute__((noinline)) Plausibility fail(Implausible rule, PlausibilityUnit unit, int32_t value, int32_t lo, int32_t hi,
                  uint8_t curve = 0, int8_t index = -1) {
  Plausibility p;
  p.rule = rule;
  p.unit = unit;
  p.value = value;
  p.lo = lo;
  p.hi = hi;
  p.curve = curve;
  p.index = index;
  return p;
}

__attribute__((noinline)) Plausibility malformed(uint8_t curve = 0) {
  Plausibility p;
  p.rule = Implausible::kMalformed;
  p.curve = curve;
  return p;
}

bool outside(int32_t v, int32_t lo, int32_t hi) { return v < lo || v > hi; }

// One present thesis curve (curve 1 or 2): finalized here.
Plausibility checkCurve(ForceCurveBase& c, uint8_t which, const RecordLimits& limits) {
  if (!c.finalize()) return malformed(which);
  if (outside(c.start_mv, kPackMinMv, limits.maxMv()))
    return fail(Implausible::kVoltage, PlausibilityUnit::kMv, c.start_mv, kPackMinMv, limits.maxMv(), which);
  const uint16_t grams = c.maxGrams();
  const int32_t p1 = c.pwm_at_1g_us;
  if (outside(p1, kThrottleMinUs, kThrottleMaxUs))
    return fail(Implausible::kPwmRange, PlausibilityUnit::kUs, p1, kThrottleMinUs, kThrottleMaxUs, which);
  const int32_t pmax = c.pwmForGrams(grams);
  if (pmax > kThrottleMaxUs)
    return fail(Implausible::kPwmRange, PlausibilityUnit::kUs, pmax, kThrottleMinUs, kThrottleMaxUs, which);
  if (grams < kRecordMinForceG)
    return fail(Implausible::kForceSpan, PlausibilityUnit::kG, grams, kRecordMinForceG, kRecordMaxForceG, which);
  const int32_t need = grams / kMaxGramsPerUs > kMinCurveSpanUs ? grams / kMaxGramsPerUs : kMinCurveSpanUs;
  if (pmax - p1 < need)
    return fail(Implausible::kFlat, PlausibilityUnit::kUs, pmax - p1, need, kThrottleMaxUs - kThrottleMinUs, which);
  return Plausibility();
}

}  // namespace

Plausibility checkCalibration(MotorCalibration& cal, const RecordLimits& limits) {
  if (!cal.first.isPresent() || cal.first.pwm_at_1g_us == 0) {
    Plausibility p;
    p.rule = Implausible::kNoCurve;
    p.curve = 1;
    return p;
  }
  Plausibility p = checkCurve(cal.first, 1, limits);
  if (!p.ok()) return p;
  const SagTable& sag = cal.sag;
  if (outside(sag.base_pwm_us, kThrottleMinUs, kThrottleMaxUs - 1))
    return fail(Implausible::kSagBase, PlausibilityUnit::kUs, sag.base_pwm_us, kThrottleMinUs,
                kThrottleMaxUs - 1);
  if (sag.offset_mv[0] != 0) return malformed(1);
  const int32_t most_mv = static_cast<int32_t>(cal.first.start_mv) * kMaxSagPercent / 100;
  for (uint8_t i = 1; i < kSagBins; ++i) {
    if (outside(sag.offset_mv[i], -static_cast<int32_t>(kMaxSagRiseMv), most_mv))
      return fail(Implausible::kSag, PlausibilityUnit::kMv, sag.offset_mv[i], -static_cast<int32_t>(kMaxSagRiseMv),
                  most_mv, 1, static_cast<int8_t>(i));
  }
  if (cal.second.start_mv == 0) {
    cal.second.clear();  // no second curve: whatever its other bytes hold is not used
    return Plausibility();
  }
  if (cal.second.pwm_at_1g_us == 0) return malformed(2);
  return checkCurve(cal.second, 2, limits);
}

Plausibility checkModelV2(const ModelV2& m, const RecordLimits& limits) {
  // Layout (what the fixed-point maths relies on; ModelV2::finalize checks the same).
  const bool coarse = m.fine_knots < m.knots;
  const uint32_t split = static_cast<uint32_t>(m.fine_knots) * m.step_dg;
  const uint32_t top = split + static_cast<uint32_t>(m.knots > m.fine_knots ? m.knots - m.fine_knots : 0) *
                                   m.coarse_step_dg;
  if (m.knots < 2 || m.knots > kV2MaxKnots || m.fine_knots < 1 || m.fine_knots > m.knots ||
      m.step_dg < (coarse ? kV2MinStepDg : kV2MinStepSmallDg) ||
      (coarse ? m.coarse_step_dg < kV2MinStepDg : m.coarse_step_dg != 0) || top > 65535u)
    return malformed();
  const int32_t start_us = (static_cast<int32_t>(m.start_q4_us) + 8) >> 4;
  if (outside(m.start_q4_us, kStartMinUs * 16L, kStartMaxUs * 16L))
    return fail(Implausible::kStartRange, PlausibilityUnit::kUs, start_us, kStartMinUs, kStartMaxUs);
  if (outside(m.rest_mv, kPackMinMv, limits.maxMv()))
    return fail(Implausible::kVoltage, PlausibilityUnit::kMv, m.rest_mv, kPackMinMv, limits.maxMv());
  if (m.second_mv != 0 && outside(m.second_mv, kPackMinMv, limits.maxMv()))
    return fail(Implausible::kVoltage, PlausibilityUnit::kMv, m.second_mv, kPackMinMv, limits.maxMv());
  const uint8_t last = static_cast<uint8_t>(m.knots - 1);
  if (m.drive_512usmv[0] == 0)
    return fail(Implausible::kFlat, PlausibilityUnit::kPercent, 0, kMinDriveGrowthPct, -1, 0, 0);
  for (uint8_t k = 1; k < m.knots; ++k) {
    if (m.drive_512usmv[k] < m.drive_512usmv[k - 1]) {
      Plausibility p;
      p.rule = Implausible::kNotMonotone;
      p.index = static_cast<int8_t>(k);
      return p;
    }
  }
  const uint32_t first = m.drive_512usmv[0];
  const uint32_t final_drive = m.drive_512usmv[last];
  if (final_drive * 100u < first * (100u + kMinDriveGrowthPct)) {
    const int32_t growth = static_cast<int32_t>((final_drive - first) * 100u / first);
    return fail(Implausible::kFlat, PlausibilityUnit::kPercent, growth, kMinDriveGrowthPct, -1);
  }
  if (outside(static_cast<int32_t>(top), 10L * kRecordMinForceG, 10L * kRecordMaxForceG))
    return fail(Implausible::kForceSpan, PlausibilityUnit::kDg, static_cast<int32_t>(top), 10L * kRecordMinForceG,
                10L * kRecordMaxForceG);
  const int32_t most_sag_mv = static_cast<int32_t>(m.rest_mv) * kMaxSagPercent / 100;
  for (uint8_t k = 0; k < m.knots; ++k) {
    const int32_t sag_mv = static_cast<int32_t>(m.sag_10mv[k]) * kV2SagUnitMv;
    if (sag_mv > most_sag_mv)
      return fail(Implausible::kSag, PlausibilityUnit::kMv, sag_mv, 0, most_sag_mv, 0, static_cast<int8_t>(k));
  }
  // The last knot's pulse at the best voltage the record saw (its sag subtracted): the
  // sweep that measured it stayed within the ESC range.
  const uint32_t best_mv = (m.second_mv > m.rest_mv ? m.second_mv : m.rest_mv) -
                           static_cast<uint32_t>(m.sag_10mv[last]) * kV2SagUnitMv;
  const uint32_t duty_q4 = (final_drive * kDriveUnitUsMv * 16u + best_mv / 2) / best_mv;
  const int32_t pwm_us = static_cast<int32_t>((m.start_q4_us + duty_q4 + 8) >> 4);
  if (pwm_us > kThrottleMaxUs + kPwmToleranceUs)
    return fail(Implausible::kPwmRange, PlausibilityUnit::kUs, pwm_us, start_us, kThrottleMaxUs, 0,
                static_cast<int8_t>(last));
  return m.dynamics.isPresent() ? checkDynamics(m.dynamics) : Plausibility();
}

Plausibility checkDynamics(const MotorDynamics& d) {
  if (d.points < 1 || d.points > kDynMaxPoints || d.lo_dg == 0 || d.lo_dg > d.hi_dg) return malformed();
  const uint16_t taus[4] = {d.up_lo_01ms, d.up_hi_01ms, d.down_lo_01ms, d.down_hi_01ms};
  for (uint16_t tau : taus)
    if (outside(tau, kDynTauMin01ms, kDynTauMax01ms))
      return fail(Implausible::kDynamics, PlausibilityUnit::kTenthMs, tau, kDynTauMin01ms, kDynTauMax01ms);
  if (d.lo_dg == d.hi_dg && (d.up_lo_01ms != d.up_hi_01ms || d.down_lo_01ms != d.down_hi_01ms))
    return malformed();
  return Plausibility();
}

}  // namespace tc

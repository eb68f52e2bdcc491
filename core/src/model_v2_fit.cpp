// Force model v2: the fitting on the board (gather_store runs it once per sweep, at `fit v2` /
// `store v2`): sort, monotone fit, start threshold from force triples, knots; refine from a
// second sweep. See model_v2.hpp for the physics and the formats; the model's own checks
// (finalize) are model_v2.cpp. Every multiplication below states its bound; `int` is 16 bits
// on the AVR, so every product that can exceed 16 bits is cast to 32 bits first.
#include "thrustcal/limits.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/model_v2_knots.hpp"
#include "thrustcal/order_stats.hpp"

namespace tc {

// ---- Fitting -------------------------------------------------------------------------------

const char* fitV2StatusText(FitV2Status status) {
  switch (status) {
    case FitV2Status::kOk: return "ok";
    case FitV2Status::kTooFewSamples: return "too few samples: sweep at least 8 PWM steps";
    case FitV2Status::kNoForce:
      return "no force: the sweep never reached 5 g (motor not spinning or cell not tared?)";
    case FitV2Status::kBadVoltage:
      return "battery reading outside 3-26 V: check the monitor wiring and the divider setting";
    case FitV2Status::kStartNotFound:
      return "start threshold not found: sweep finer (<= 10 us steps) from 1000 us to full force";
    case FitV2Status::kVoltagesTooClose:
      return "second sweep within 0.5 V of the first: refine needs another voltage";
    case FitV2Status::kNoModel: return "no model to refine: fit a first sweep";
  }
  return "unknown";
}

bool ModelV2FitterBase::add(uint16_t pwm_us, int16_t force_dg, uint16_t vbat_mv) {
  if (count_ >= capacity_) return false;
  samples_[count_].pwm_us = pwm_us;
  samples_[count_].force_dg = force_dg;
  samples_[count_].vbat_mv = vbat_mv;
  ++count_;
  return true;
}

namespace {

// PWM (1/16 us) and reading where the fitted (monotone) force first reaches force_dg,
// linear between the two samples around it. False above the sweep's largest force and below
// the first sample's force (a sweep that starts with the motor already pushing).
struct SweepAt {
  int32_t pwm_q4;
  int32_t vbat_mv;
};

bool sweepAt(const SweepPointV2* s, uint16_t n, int32_t force_dg, SweepAt& out) {
  uint16_t j = 0;
  while (j < n && s[j].force_dg < force_dg) ++j;
  if (j == n || (j == 0 && s[0].force_dg > force_dg)) return false;
  if (j == 0 || s[j].force_dg == s[j - 1].force_dg) {
    out.pwm_q4 = static_cast<int32_t>(s[j].pwm_us) * 16;
    out.vbat_mv = s[j].vbat_mv;
    return true;
  }
  const int32_t df = s[j].force_dg - s[j - 1].force_dg;  // > 0
  const int32_t num = force_dg - s[j - 1].force_dg;       // 1..df
  const int32_t dp = (static_cast<int32_t>(s[j].pwm_us) - s[j - 1].pwm_us) * 16;
  const int32_t dv = static_cast<int32_t>(s[j].vbat_mv) - s[j - 1].vbat_mv;
  out.pwm_q4 = static_cast<int32_t>(s[j - 1].pwm_us) * 16 + (dp * num + df / 2) / df;
  out.vbat_mv = s[j - 1].vbat_mv + (dv * num) / df;
  return true;
}

// Drive (512 us*mV) of a sweep point with start s; at least 1 (0 is the origin).
uint16_t driveOf(int32_t pwm_q4, int32_t vbat_mv, int32_t start_q4) {
  const int32_t span = pwm_q4 - start_q4;
  if (span <= 0) return 1;
  const uint32_t d = (static_cast<uint32_t>(span) * static_cast<uint32_t>(vbat_mv)) >> 13;
  if (d < 1) return 1;
  return d > 65535u ? 65535u : static_cast<uint16_t>(d);
}

// The samples for the monotone fit (order_stats.hpp's poolAdjacentViolators), unweighted:
// block k's mean (rounded) in samples[k].force_dg, its size in weights[k].
struct PavaPool {
  struct Block {
    int32_t mean;
    uint16_t size;
  };
  SweepPointV2* samples;
  uint16_t* weights;

  Block point(uint16_t i) const { return Block{samples[i].force_dg, 1}; }
  static bool above(const Block& lo, const Block& hi) { return lo.mean > hi.mean; }
  static Block merge(const Block& lo, const Block& hi) {
    const int32_t total = static_cast<int32_t>(hi.size) + lo.size;
    const int32_t sum = lo.mean * lo.size + hi.mean * hi.size;
    return Block{(sum >= 0 ? sum + total / 2 : sum - total / 2) / total,
                 static_cast<uint16_t>(hi.size + lo.size)};
  }
  void keep(uint16_t k, const Block& b) {
    samples[k].force_dg = static_cast<int16_t>(b.mean);
    weights[k] = b.size;
  }
  Block kept(uint16_t k) const { return Block{samples[k].force_dg, weights[k]}; }
  static uint16_t points(const Block& b) { return b.size; }
  void fill(uint16_t first, uint16_t end, const Block& b) {
    for (uint16_t i = first; i < end; ++i) samples[i].force_dg = static_cast<int16_t>(b.mean);
  }
};

}  // namespace

FitV2Report ModelV2FitterBase::prepare() {
  FitV2Report rep;
  const uint16_t n = count_;
  rep.samples_used = n;
  if (n < 8) {
    rep.status = FitV2Status::kTooFewSamples;
    return rep;
  }
  for (uint16_t i = 0; i < n; ++i) {
    if (!isSaneV2Mv(samples_[i].vbat_mv)) {
      rep.status = FitV2Status::kBadVoltage;
      return rep;
    }
  }
  // Sort by PWM (a sweep is ascending already: linear time then).
  insertionSort(samples_, n,
                [](const SweepPointV2& a, const SweepPointV2& b) { return a.pwm_us < b.pwm_us; });
  // Monotone (non-decreasing) force in PWM: pool adjacent violators, in place.
  PavaPool pool{samples_, weights_};
  rep.violations = poolAdjacentViolators(pool, n);
  rep.max_force_dg = samples_[n - 1].force_dg;
  if (rep.max_force_dg < static_cast<int16_t>(10 * kRecordMinForceG)) {
    rep.status = FitV2Status::kNoForce;
    return rep;
  }
  // Resting reading: mean over the samples below 1/64 of the largest force (the motor barely
  // turns there: no sag yet); the first sample if none.
  const int16_t quiet_dg = static_cast<int16_t>(rep.max_force_dg / 64);
  uint32_t sum_mv = 0;
  uint16_t quiet = 0;
  for (uint16_t i = 0; i < n && samples_[i].force_dg <= quiet_dg; ++i) {
    sum_mv += samples_[i].vbat_mv;
    ++quiet;
  }
  rep.rest_mv = quiet ? static_cast<uint16_t>((sum_mv + quiet / 2) / quiet) : samples_[0].vbat_mv;
  rep.status = FitV2Status::kOk;
  return rep;
}

FitV2Report ModelV2FitterBase::fit(ModelV2& out) {
  out.clear();
  FitV2Report rep = prepare();
  if (rep.status != FitV2Status::kOk) return rep;
  const uint16_t n = count_;
  const int32_t fmax = rep.max_force_dg;

  // Start threshold from force triples F, 2F, 4F (F = fmax * j / 256, j = 2..16): for a power
  // law the PWMs satisfy (p2 - s)^2 = (p1 - s)(p3 - s). The sag makes V differ between the
  // three points; the drive, not the PWM, is what is geometric, so the PWMs are rescaled to
  // the middle point's voltage around the current estimate and the formula is iterated.
  int16_t est[15];
  uint8_t n_est = 0;
  // The low end (F up to 6 % of the largest force, 4F up to 25 %) because that is where a
  // motor is closest to a power law: higher up the winding's IR drop and the propeller's
  // rising thrust coefficient bend the curve, and the estimate drifts late (docs/model_v2.md).
  for (uint8_t j = 2; j <= 16; ++j) {
    const int32_t f1 = fmax * j / 256;
    if (f1 < 5) continue;
    SweepAt a1, a2, a3;
    if (!sweepAt(samples_, n, f1, a1) || !sweepAt(samples_, n, 2 * f1, a2) ||
        !sweepAt(samples_, n, 4 * f1, a3))
      continue;
    int32_t s = 0;
    bool ok = true;
    bool first = true;
    for (uint8_t it = 0; ok && it < 4; ++it) {
      int32_t p1 = a1.pwm_q4, p2 = a2.pwm_q4, p3 = a3.pwm_q4;
      if (!first) {
        // (p - s) * V / V2: |p - s| < 2^15 (q4), V < 2^15: product < 2^30.
        p1 = s + (p1 - s) * a1.vbat_mv / a2.vbat_mv;
        p3 = s + (p3 - s) * a3.vbat_mv / a2.vbat_mv;
      }
      first = false;
      const int32_t u = p2 - p1;
      const int32_t w = p3 - p1;
      const int32_t den = w - 2 * u;
      if (u <= 0 || den <= 0) {
        ok = false;
        break;
      }
      s = p1 - (u * u + den / 2) / den;  // u < 2^15: u^2 < 2^30
      if (s < kV2StartMinQ4Us || s >= a1.pwm_q4) ok = false;
    }
    if (ok) est[n_est++] = static_cast<int16_t>(s);
  }
  rep.estimates = n_est;
  if (n_est < 3) {
    rep.status = FitV2Status::kStartNotFound;
    return rep;
  }
  const int32_t start_q4 = medianInPlace(est, n_est);

  ModelV2 m;
  placeV2Knots(m, static_cast<uint16_t>(fmax));
  m.start_q4_us = static_cast<uint16_t>(start_q4);
  m.rest_mv = rep.rest_mv;
  uint16_t prev = 1;
  for (uint8_t k = 0; k < m.knots; ++k) {
    SweepAt at;
    if (!sweepAt(samples_, n, m.knotForceDg(k), at)) {
      rep.status = FitV2Status::kStartNotFound;  // the sweep did not start below the first knot
      return rep;
    }
    uint16_t d = driveOf(at.pwm_q4, at.vbat_mv, start_q4);
    if (d < prev) d = prev;
    m.drive_512usmv[k] = d;
    prev = d;
    int32_t sag = (static_cast<int32_t>(rep.rest_mv) - at.vbat_mv + kV2SagUnitMv / 2) / kV2SagUnitMv;
    m.sag_10mv[k] = static_cast<uint8_t>(sag < 0 ? 0 : (sag > 255 ? 255 : sag));
  }
  if (!m.finalize()) {
    rep.status = FitV2Status::kStartNotFound;
    return rep;
  }
  rep.start_q4_us = m.start_q4_us;
  out = m;
  return rep;
}

FitV2Report ModelV2FitterBase::refine(ModelV2& model) {
  FitV2Report rep;
  if (!model.isPresent()) {
    rep.status = FitV2Status::kNoModel;
    return rep;
  }
  rep = prepare();
  if (rep.status != FitV2Status::kOk) return rep;
  const int32_t gap = static_cast<int32_t>(rep.rest_mv) - model.rest_mv;
  if (gap < kV2MinVoltageGapMv && gap > -static_cast<int32_t>(kV2MinVoltageGapMv)) {
    rep.status = FitV2Status::kVoltagesTooClose;
    return rep;
  }
  const uint16_t n = count_;
  const int32_t s_old = model.start_q4_us;
  // Direct start estimate per knot: (pA - s) VA = (pB - s) VB. Knots below 1/16 of the
  // common range are skipped (flat force there: PWM poorly defined by force).
  const int32_t common = rep.max_force_dg < static_cast<int32_t>(model.maxForceDg())
                             ? rep.max_force_dg
                             : static_cast<int32_t>(model.maxForceDg());
  int16_t est[kV2MaxKnots];
  uint8_t n_est = 0;
  for (uint8_t k = 0; k < model.knots; ++k) {
    const int32_t f = model.knotForceDg(k);
    if (f > common) break;
    if (f * 16 < common) continue;
    SweepAt b;
    if (!sweepAt(samples_, n, f, b)) break;
    const int32_t va = static_cast<int32_t>(model.rest_mv) - model.sag_10mv[k] * kV2SagUnitMv;
    const int32_t den = va - b.vbat_mv;
    if (den < 300 && den > -300) continue;
    // All in 1/16 us * mV: drive * 8192 < 2^29, s * VA < 2^29, pB * VB < 2^29.
    const int32_t xa = static_cast<int32_t>(model.drive_512usmv[k]) * 8192 + s_old * va;
    const int32_t xb = b.pwm_q4 * b.vbat_mv;
    const int32_t s = (xa - xb) / den;
    if (s < kV2StartMinQ4Us || s > kV2StartMaxQ4Us) continue;
    est[n_est++] = static_cast<int16_t>(s);
  }
  rep.estimates = n_est;
  if (n_est < 3) {
    rep.status = FitV2Status::kStartNotFound;
    return rep;
  }
  const int32_t s_new = medianInPlace(est, n_est);

  ModelV2 m = model;
  m.start_q4_us = static_cast<uint16_t>(s_new);
  uint16_t prev = 1;
  for (uint8_t k = 0; k < model.knots; ++k) {
    const int32_t f = model.knotForceDg(k);
    const int32_t va = static_cast<int32_t>(model.rest_mv) - model.sag_10mv[k] * kV2SagUnitMv;
    // Sweep A's drive moved to the new start: + (s_old - s_new) * VA; |.| < 2^15 * 2^15.
    int32_t d = static_cast<int32_t>(model.drive_512usmv[k]) + (((s_old - s_new) * va) >> 13);
    SweepAt b;
    if (f <= rep.max_force_dg && sweepAt(samples_, n, f, b))
      d = (d + driveOf(b.pwm_q4, b.vbat_mv, s_new) + 1) / 2;
    if (d < prev) d = prev;
    if (d > 65535) d = 65535;
    m.drive_512usmv[k] = static_cast<uint16_t>(d);
    prev = static_cast<uint16_t>(d);
  }
  m.second_mv = rep.rest_mv;
  m.flags = static_cast<uint8_t>(m.flags | kV2Refined);
  if (!m.finalize()) {
    rep.status = FitV2Status::kStartNotFound;
    return rep;
  }
  rep.start_q4_us = m.start_q4_us;
  model = m;
  return rep;
}

}  // namespace tc

// Step-log fits (thrustcal/dynamics_fit.hpp): the motor's time constant through the bench's
// response, the bench's response from a weight step, the law over the operating points.
//
// Both models are evaluated on the log's own grid and compared by least squares, with the
// levels before and after the step solved in closed form for each candidate (so the search is
// over the time constants only: Brent's method in one dimension for the motor, Nelder-Mead in
// two for the bench's time constant and the step's instant).
#include "thrustcal/dynamics_fit.hpp"

#include <math.h>

#include "thrustcal/flash_text.hpp"

namespace tc {

const char* stepFitWhyText(StepFitWhy why) {
  switch (why) {
    case StepFitWhy::kOk: return TC_FLASH_TEXT("ok");
    case StepFitWhy::kTooShort: return TC_FLASH_TEXT("log too short or the step too near its end");
    case StepFitWhy::kNoStep: return TC_FLASH_TEXT("no step in the force (less than 8x the residual)");
    case StepFitWhy::kAtBound: return TC_FLASH_TEXT("time constant at the search's bound (not a first-order lag)");
    case StepFitWhy::kNoBench: return TC_FLASH_TEXT("bench response not identified");
  }
  return TC_FLASH_TEXT("?");
}

BenchResponse BenchStepFit::response() const {
  BenchResponse r;
  if (!ok()) return r;
  r.stages = stages;
  r.tau_01ms = secondsTo01ms(tau_s);
  return r;
}

namespace {

constexpr uint16_t kYieldEvery = 15;  // StepLog::yield every 16 samples (mask)

BenchResponse benchOf(uint8_t stages, float tau_s) {
  BenchResponse r;
  r.stages = stages;
  r.tau_01ms = secondsTo01ms(tau_s);
  return r;
}
}  // namespace

namespace {

constexpr uint16_t kMinSamples = 40;
constexpr float kTauMinS = 0.005f;
constexpr float kTauMaxS = 1.5f;

// The log seen through `stride`: sample j is the mean of blocks j*stride .. j*stride+stride-1,
// its centre at (j + 0.5) * dt.
struct Samples {
  const StepLog* slog;
  uint8_t stride;
  uint16_t count;
  float dt;
  float mean;   // of all samples (the sums below are taken about it, for float precision)
  float scale;  // grams per summed decigram
  float at(uint16_t j) const {
    int32_t sum = 0;
    const int16_t* p = slog->force_dg + j * stride;
    for (uint8_t i = 0; i < stride; ++i) sum += p[i];
    return static_cast<float>(sum) * scale - mean;
  }
};

Samples makeSamples(const StepLog& slog, uint8_t stride) {
  Samples s;
  s.slog = &slog;
  s.stride = stride == 0 ? 1 : stride;
  s.count = static_cast<uint16_t>(slog.blocks / s.stride);
  s.dt = slog.block_s * static_cast<float>(s.stride);
  s.scale = 0.1f / static_cast<float>(s.stride);
  s.mean = 0.0f;
  float sum = 0.0f;
  for (uint16_t j = 0; j < s.count; ++j) sum += s.at(j);
  if (s.count != 0) s.mean = sum / static_cast<float>(s.count);
  return s;
}

// Least squares of y = c0 + c1 * psi from sums about the samples' mean. A clean step's residual
// is 1e-5 of the sums it is the difference of, near float's own precision: the samples are summed
// in chunks of kChunk and the chunks added with Kahan's compensation, so rounding stays well
// below the residual and the search sees the model's changes, not the sums' noise.
struct LineSums {
  static constexpr uint8_t kChunk = 32;
  enum { kN, kP, kPP, kY, kYP, kYY, kCount };
  float chunk[kCount] = {};
  float total[kCount] = {};
  float carry[kCount] = {};
  uint8_t in_chunk = 0;
  void add(float y, float psi) {
    chunk[kN] += 1.0f;
    chunk[kP] += psi;
    chunk[kPP] += psi * psi;
    chunk[kY] += y;
    chunk[kYP] += y * psi;
    chunk[kYY] += y * y;
    if (++in_chunk == kChunk) fold();
  }
  void fold() {
    for (uint8_t i = 0; i < kCount; ++i) {
      const float v = chunk[i] - carry[i];
      const float t = total[i] + v;
      carry[i] = (t - total[i]) - v;
      total[i] = t;
      chunk[i] = 0.0f;
    }
    in_chunk = 0;
  }
  // SSE of the best line; c0, c1 in grams (the samples' mean added back).
  float solve(float mean, float& c0, float& c1) {
    fold();
    const float n = total[kN], sp = total[kP], sy = total[kY];
    const float pp = total[kPP] - sp * sp / n;
    const float yp = total[kYP] - sp * sy / n;
    const float yy = total[kYY] - sy * sy / n;
    if (!(pp > 1e-9f)) {
      c1 = 0.0f;
      c0 = mean + sy / n;
      return yy;
    }
    c1 = yp / pp;
    c0 = mean + (sy - c1 * sp) / n;
    const float sse = yy - yp * c1;
    return sse > 0.0f ? sse : 0.0f;
  }
};

// `stages` trapezoidal first-order stages on the sample grid.
struct StageChain {
  uint8_t n = 0;
  float a = 0, g = 0;
  float state[kBenchMaxStages] = {};
  float last_in[kBenchMaxStages] = {};
  StageChain(const BenchResponse& bench, float dt) : n(bench.stages) {
    const float tau = bench.tauS();
    a = (2.0f * tau - dt) / (2.0f * tau + dt);
    g = dt / (2.0f * tau + dt);
  }
  float push(float u) {
    for (uint8_t i = 0; i < n; ++i) {
      const float y = a * state[i] + g * (u + last_in[i]);
      last_in[i] = u;
      state[i] = y;
      u = y;
    }
    return u;
  }
};

// The drive's deviation from a clean step after it, in units of the step: the bus sags under
// the current surge of a step up (and rises on a step down), so (to - start) * V(t) reaches
// its final value only as the surge decays. Zero without a voltage slog.
struct DriveDip {
  const StepLog* slog = nullptr;
  float per_mv = 0.0f;  // (to - start) / (drive_to - drive_from), per mV
  float end_mv = 0.0f;  // the bus at the log's end
  float per_value = 0.0f;  // voltage values per second
  uint16_t values = 0;
  explicit DriveDip(const StepLog& l) : slog(&l) {
    if (l.vbat_mv == nullptr || l.blocks < 4 * kDynBlocksPerVbat) return;
    values = static_cast<uint16_t>(l.blocks / kDynBlocksPerVbat);
    const float before = static_cast<float>(l.vbat_mv[0]);
    end_mv = 0.5f * static_cast<float>(l.vbat_mv[values - 1]) + 0.5f * static_cast<float>(l.vbat_mv[values - 2]);
    const float to = static_cast<float>(l.to_us) - l.start_us;
    const float from = static_cast<float>(l.from_us) - l.start_us;
    const float step = to * end_mv - from * before;
    if (to > 0.0f && from > 0.0f && fabsf(step) > 1.0f) per_mv = to / step;
    per_value = 1.0f / (l.block_s * kDynBlocksPerVbat);
  }
  // At time t (s from the log's start, after the step): the voltage log interpolated.
  float at(float t) const {
    if (per_mv == 0.0f) return 0.0f;
    const float pos = t * per_value - 0.5f;
    if (pos <= 0.0f) return per_mv * (static_cast<float>(slog->vbat_mv[0]) - end_mv);
    const uint16_t i = static_cast<uint16_t>(pos);
    if (i + 1 >= values) return per_mv * (static_cast<float>(slog->vbat_mv[values - 1]) - end_mv);
    const float f = pos - static_cast<float>(i);
    const float v = (1.0f - f) * static_cast<float>(slog->vbat_mv[i]) + f * static_cast<float>(slog->vbat_mv[i + 1]);
    return per_mv * (v - end_mv);
  }
};

// The motor's normalised force response (0 before the step, 1 at the end): its speed a
// first-order lag of tau behind the drive (a step plus the dip), force = speed^2 with
// q = sqrt(to / from); then the bench. Returns the fit's SSE.
float motorSse(const Samples& s, const StepLog& slog, const BenchResponse& bench, const DriveDip& dip, float tau,
               float q, float& c0, float& c1) {
  StageChain chain(bench, s.dt);
  LineSums sums;
  const float r = expf(-s.dt / tau);
  const float a = (2.0f * tau - s.dt) / (2.0f * tau + s.dt), g = s.dt / (2.0f * tau + s.dt);
  float e = -1.0f;  // exp(-(t - step)/tau) once past the step
  float lag = 0.0f, last_dip = 0.0f;  // the dip through the same lag (trapezoidal)
  for (uint16_t j = 0; j < s.count; ++j) {
    const float t_log = (static_cast<float>(j) + 0.5f) * s.dt;
    const float t = t_log - slog.step_s;
    float phi = 0.0f;
    if (t > 0.0f) {
      e = e < 0.0f ? expf(-t / tau) : e * r;
      const float d = dip.at(t_log);
      lag = a * lag + g * (d + last_dip);
      last_dip = d;
      const float rise = 1.0f - e + lag;
      phi = rise * (2.0f + (q - 1.0f) * rise) / (q + 1.0f);
    }
    sums.add(s.at(j), chain.push(phi));
    if ((j & kYieldEvery) == 0 && slog.yield) slog.yield();
  }
  return sums.solve(s.mean, c0, c1);
}

// Brent's minimisation of f on [lo, hi] (golden section with parabolic steps), to `tol`.
template <class F>
float brentMinimize(F f, float lo, float hi, float tol, float& best_f) {
  const float kGold = 0.381966f;
  float a = lo, b = hi;
  float x = a + kGold * (b - a), w = x, v = x;
  float fx = f(x), fw = fx, fv = fx;
  float d = 0.0f, e = 0.0f;
  for (int iter = 0; iter < 60; ++iter) {
    const float m = 0.5f * (a + b);
    const float tol1 = tol * 0.5f + 1e-6f;
    if (fabsf(x - m) <= 2.0f * tol1 - 0.5f * (b - a)) break;
    bool golden = true;
    if (fabsf(e) > tol1) {
      float r = (x - w) * (fx - fv);
      float q = (x - v) * (fx - fw);
      float p = (x - v) * q - (x - w) * r;
      q = 2.0f * (q - r);
      if (q > 0.0f) p = -p;
      q = fabsf(q);
      if (fabsf(p) < fabsf(0.5f * q * e) && p > q * (a - x) && p < q * (b - x)) {
        e = d;
        d = p / q;
        const float u = x + d;
        if (u - a < 2.0f * tol1 || b - u < 2.0f * tol1) d = x < m ? tol1 : -tol1;
        golden = false;
      }
    }
    if (golden) {
      e = (x < m ? b : a) - x;
      d = kGold * e;
    }
    const float u = fabsf(d) >= tol1 ? x + d : x + (d > 0.0f ? tol1 : -tol1);
    const float fu = f(u);
    if (fu <= fx) {
      if (u < x) b = x; else a = x;
      v = w, fv = fw, w = x, fw = fx, x = u, fx = fu;
    } else {
      if (u < x) a = u; else b = u;
      if (fu <= fw || w == x) {
        v = w, fv = fw, w = u, fw = fu;
      } else if (fu <= fv || v == x || v == w) {
        v = u, fv = fu;
      }
    }
  }
  best_f = fx;
  return x;
}

// The area between 1 and the normalised response after the step (seconds): the mean delay of
// everything between the pulse and the reading, if it settles within the log.
float meanDelay(const Samples& s, float step_s, float before, float after) {
  if (fabsf(after - before) < 1e-3f) return 0.0f;
  const float inv = 1.0f / (after - before);
  float area = 0.0f;
  for (uint16_t j = 0; j < s.count; ++j) {
    const float t = (static_cast<float>(j) + 0.5f) * s.dt - step_s;
    if (t > 0.0f) area += 1.0f - (s.at(j) + s.mean - before) * inv;
  }
  return area * s.dt;
}

// Mean of samples [from, to).
float levelMean(const Samples& s, uint16_t from, uint16_t to) {
  float sum = 0.0f;
  for (uint16_t j = from; j < to; ++j) sum += s.at(j);
  return to > from ? s.mean + sum / static_cast<float>(to - from) : s.mean;
}

}  // namespace

MotorStepFit fitMotorStep(const StepLog& slog, const BenchResponse& bench, uint8_t stride) {
  MotorStepFit fit;
  if (!bench.isValid()) {
    fit.why = StepFitWhy::kNoBench;
    return fit;
  }
  const Samples s = makeSamples(slog, stride);
  const float step_at = slog.step_s / s.dt;
  if (s.count < kMinSamples || step_at < 5.0f || step_at > static_cast<float>(s.count) - 20.0f) return fit;
  // First guess of sqrt(to / from) from the levels before the step and at the log's end.
  const float before = levelMean(s, 0, static_cast<uint16_t>(step_at - 1.0f));
  const float after = levelMean(s, static_cast<uint16_t>(s.count - s.count / 8), s.count);
  float q = (before > 1.0f && after > 1.0f) ? sqrtf(after / before) : 1.0f;
  const DriveDip dip(slog);
  // The search starts around the response's mean delay less the bench's (the area between the
  // normalised response and 1), and only refines when sqrt(to / from) moved.
  float lo = logf(kTauMinS), hi = logf(kTauMaxS);
  const float delay = meanDelay(s, slog.step_s, before, after) - bench.delayS();
  if (delay > 2.0f * kTauMinS && delay < 0.5f * kTauMaxS) lo = logf(0.5f * delay), hi = logf(2.0f * delay);
  float c0 = 0, c1 = 0, sse = 0;
  float x = 0;
  for (int pass = 0; pass < 3; ++pass) {
    x = brentMinimize([&](float lt) { return motorSse(s, slog, bench, dip, expf(lt), q, c0, c1); }, lo, hi, 2e-3f,
                      sse);
    motorSse(s, slog, bench, dip, expf(x), q, c0, c1);
    const float to = c0 + c1;
    const float q_new = (c0 > 1.0f && to > 1.0f) ? sqrtf(to / c0) : 1.0f;
    if (fabsf(q_new - q) < 2e-3f * q) break;
    q = q_new;
    lo = x - 0.2f, hi = x + 0.2f;  // the next pass only refines
  }
  fit.tau_s = expf(x);
  fit.from_g = c0;
  fit.to_g = c0 + c1;
  fit.rms_g = sqrtf(sse / static_cast<float>(s.count));
  if (fabsf(c1) < 8.0f * fit.rms_g || fabsf(c1) < 1.0f) {
    fit.why = StepFitWhy::kNoStep;
  } else if (fit.tau_s < kTauMinS * 1.02f || fit.tau_s > kTauMaxS * 0.98f) {
    fit.why = StepFitWhy::kAtBound;
  } else {
    fit.why = StepFitWhy::kOk;
  }
  return fit;
}

namespace {

// Gamma(n, 1) quantiles at 10 %, 50 % and 90 % (the start of the bench fit's search).
constexpr float kErlangQ10[kBenchMaxStages] = {0.1054f, 0.5318f, 1.1021f, 1.7448f};
constexpr float kErlangQ50[kBenchMaxStages] = {0.6931f, 1.6783f, 2.6741f, 3.6721f};
constexpr float kErlangQ90[kBenchMaxStages] = {2.3026f, 3.8897f, 5.3223f, 6.6808f};

// Integral from 0 to x of the Erlang(n) step response: x - n + e^-x sum_{i<n} (n - i) x^i / i!.
float erlangIntegral(uint8_t n, float x, float exp_minus_x) {
  float term = 1.0f, poly = 0.0f;
  for (uint8_t i = 0; i < n; ++i) {
    poly += static_cast<float>(n - i) * term;
    term = term * x / static_cast<float>(i + 1);
  }
  return x - static_cast<float>(n) + exp_minus_x * poly;
}

// SSE of a unit step at step_s through n stages of tau, each sample the exact mean over its
// span (so a step inside a sample is seen as the ADC saw it).
float benchSse(const Samples& s, uint8_t n, float tau, float step_s, float& c0, float& c1) {
  LineSums sums;
  const float dx = s.dt / tau;
  const float r = expf(-dx);
  float x = -step_s / tau;  // at the first sample's start
  float e = -1.0f;
  float g_prev = 0.0f;
  for (uint16_t j = 0; j < s.count; ++j) {
    const float x_end = x + dx;
    float g_end = 0.0f;
    if (x_end > 0.0f) {
      e = e < 0.0f ? expf(-x_end) : e * r;
      g_end = erlangIntegral(n, x_end, e);
    }
    sums.add(s.at(j), (g_end - g_prev) / dx);
    g_prev = g_end;
    x = x_end;
    if ((j & kYieldEvery) == 0 && s.slog->yield) s.slog->yield();
  }
  return sums.solve(s.mean, c0, c1);
}

// Time at which the samples first cross `level` (between before and after), interpolated.
float crossing(const Samples& s, float before, float after, float fraction) {
  const float level = before + fraction * (after - before) - s.mean;
  const bool rising = after > before;
  float prev = s.at(0);
  for (uint16_t j = 1; j < s.count; ++j) {
    const float y = s.at(j);
    if (rising ? (y >= level && prev < level) : (y <= level && prev > level)) {
      const float f = (level - prev) / (y - prev);
      return (static_cast<float>(j - 1) + 0.5f + f) * s.dt;
    }
    prev = y;
  }
  return -1.0f;
}

struct Point2 {
  float x, y, f;
};

// Nelder-Mead in two dimensions from `start` with steps (dx, dy); `evals` evaluations at most.
template <class F>
Point2 nelderMead(F f, float x0, float y0, float dx, float dy, uint8_t evals) {
  Point2 p[3] = {{x0, y0, 0}, {x0 + dx, y0, 0}, {x0, y0 + dy, 0}};
  for (Point2& q : p) q.f = f(q.x, q.y);
  uint8_t used = 3;
  while (used + 2 <= evals) {
    // order: p[0] best, p[2] worst
    for (uint8_t i = 0; i < 2; ++i)
      for (uint8_t k = 0; k + 1 < 3 - i; ++k)
        if (p[k + 1].f < p[k].f) {
          const Point2 t = p[k];
          p[k] = p[k + 1];
          p[k + 1] = t;
        }
    const float cx = 0.5f * (p[0].x + p[1].x), cy = 0.5f * (p[0].y + p[1].y);
    Point2 refl = {2.0f * cx - p[2].x, 2.0f * cy - p[2].y, 0};
    refl.f = f(refl.x, refl.y);
    ++used;
    if (refl.f < p[0].f) {
      Point2 exp = {3.0f * cx - 2.0f * p[2].x, 3.0f * cy - 2.0f * p[2].y, 0};
      exp.f = f(exp.x, exp.y);
      ++used;
      p[2] = exp.f < refl.f ? exp : refl;
    } else if (refl.f < p[1].f) {
      p[2] = refl;
    } else {
      Point2 con = {0.5f * (cx + p[2].x), 0.5f * (cy + p[2].y), 0};
      con.f = f(con.x, con.y);
      ++used;
      if (con.f < p[2].f) {
        p[2] = con;
      } else {  // shrink towards the best
        for (uint8_t i = 1; i < 3 && used < evals; ++i) {
          p[i].x = 0.5f * (p[0].x + p[i].x);
          p[i].y = 0.5f * (p[0].y + p[i].y);
          p[i].f = f(p[i].x, p[i].y);
          ++used;
        }
      }
    }
  }
  Point2 best = p[0];
  for (const Point2& q : p)
    if (q.f < best.f) best = q;
  return best;
}

}  // namespace

BenchStepFit fitBenchStep(const StepLog& slog) {
  BenchStepFit fit;
  uint8_t stride = 1;
  while (slog.blocks / stride > 320) ++stride;
  const Samples s = makeSamples(slog, stride);
  if (s.count < kMinSamples) return fit;
  const float before = levelMean(s, 0, 5);
  const float after = levelMean(s, static_cast<uint16_t>(s.count - s.count / 8), s.count);
  const float t10 = crossing(s, before, after, 0.1f);
  const float t50 = crossing(s, before, after, 0.5f);
  const float t90 = crossing(s, before, after, 0.9f);
  if (t10 < 0.0f || t50 < 0.0f || t90 <= t10) {
    fit.why = StepFitWhy::kNoStep;
    return fit;
  }
  float best_sse = -1.0f;
  for (uint8_t n = 1; n <= kBenchMaxStages; ++n) {
    const float tau0 = (t90 - t10) / (kErlangQ90[n - 1] - kErlangQ10[n - 1]);
    const float step0 = t50 - kErlangQ50[n - 1] * tau0;
    float c0 = 0, c1 = 0;
    const Point2 p = nelderMead(
        [&](float step_s, float log_tau) { return benchSse(s, n, expf(log_tau), step_s, c0, c1); }, step0,
        logf(tau0), 0.3f * tau0, 0.2f, 70);
    // A stage more must earn its place: 2 % less residual.
    if (best_sse < 0.0f || p.f < 0.98f * best_sse) {
      best_sse = p.f;
      fit.stages = n;
      fit.tau_s = expf(p.y);
      fit.step_s = p.x;
    }
  }
  float c0 = 0, c1 = 0;
  const float sse = benchSse(s, fit.stages, fit.tau_s, fit.step_s, c0, c1);
  fit.from_g = c0;
  fit.to_g = c0 + c1;
  fit.rms_g = sqrtf(sse / static_cast<float>(s.count));
  if (fabsf(c1) < 8.0f * fit.rms_g || fabsf(c1) < 1.0f) {
    fit.why = StepFitWhy::kNoStep;
  } else if (!benchOf(fit.stages, fit.tau_s).isValid() || fit.step_s < 0.0f) {
    fit.why = StepFitWhy::kAtBound;
  } else {
    fit.why = StepFitWhy::kOk;
  }
  return fit;
}

}  // namespace tc

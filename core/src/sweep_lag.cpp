// The sweep's lag and its correction (thrustcal/sweep_lag.hpp).
#include "thrustcal/sweep_lag.hpp"

#include <math.h>

namespace tc {

namespace {

// e^-x * sum_{k < n} x^k / k!
float poissonTail(uint8_t n, float x) {
  float term = 1.0f, sum = 0.0f;
  for (uint8_t k = 0; k < n; ++k) {
    sum += term;
    term = term * x / static_cast<float>(k + 1);
  }
  return expf(-x) * sum;
}

}  // namespace

float lagTail(float t_s, float tau_s, const BenchResponse& bench) {
  if (!(t_s > 0.0f)) return 1.0f;
  const uint8_t n = bench.isValid() ? bench.stages : 0;
  if (n == 0) return expf(-t_s / tau_s);
  const float tb = bench.tauS();
  const float r = tb / tau_s;
  if (fabsf(1.0f - r) < 0.1f) {  // one Erlang stage more, the same mean delay
    const float ta = (static_cast<float>(n) * tb + tau_s) / static_cast<float>(n + 1);
    return poissonTail(static_cast<uint8_t>(n + 1), t_s / ta);
  }
  // P(T_cell > t) + e^-t/tau * integral of the cell's density against e^s/tau, written so that
  // no exponential grows (a motor faster than a cell stage gives a negative rate).
  float c = 1.0f;
  for (uint8_t k = 0; k < n; ++k) c /= (1.0f - r);
  const float y = t_s * (1.0f / tb - 1.0f / tau_s);
  float term = 1.0f, sum = 0.0f;
  for (uint8_t k = 0; k < n; ++k) {
    sum += term;
    term = term * y / static_cast<float>(k + 1);
  }
  const float tail = poissonTail(n, t_s / tb) + c * (expf(-t_s / tau_s) - expf(-t_s / tb) * sum);
  return tail < 0.0f ? 0.0f : (tail > 1.0f ? 1.0f : tail);
}

void SweepLagCorrector::start(const MotorDynamics& dynamics, const BenchResponse& bench) {
  *this = SweepLagCorrector();
  dynamics_ = &dynamics;
  bench_ = bench;
}

SweepPointV2 SweepLagCorrector::correct(const SweepPointV2& p, float lag_steps, float slope_dg) {
  const float shift = lag_steps * slope_dg;
  float f = static_cast<float>(p.force_dg) + shift;
  if (f > 32767.0f) f = 32767.0f;
  if (f < -32768.0f) f = -32768.0f;
  SweepPointV2 out = p;
  out.force_dg = static_cast<int16_t>(f < 0.0f ? f - 0.5f : f + 0.5f);
  const int16_t moved = static_cast<int16_t>(out.force_dg - p.force_dg);
  const int16_t size = moved < 0 ? static_cast<int16_t>(-moved) : moved;
  if (size > largest_dg_) largest_dg_ = size;
  last_lag_steps_ = lag_steps;
  return out;
}

bool SweepLagCorrector::push(float edge_s, float read_s, const SweepPointV2& raw, SweepPointV2& out) {
  for (uint8_t i = kEdges - 1; i > 0; --i) edges_[i] = edges_[i - 1];
  edges_[0] = edge_s;
  if (edge_count_ < kEdges) ++edge_count_;
  float lag = 0.0f;
  if (dynamics_ != nullptr && dynamics_->isPresent()) {
    const float force_g = raw.force_dg > 10 ? 0.1f * static_cast<float>(raw.force_dg) : 1.0f;
    const float tau = dynamics_->tauUpS(force_g);
    for (uint8_t i = 0; i < edge_count_; ++i) lag += lagTail(read_s - edges_[i], tau, bench_);
  }
  bool ready = false;
  if (pending_ >= 1) {
    const float slope = pending_ >= 2 ? 0.5f * static_cast<float>(raw.force_dg - prev2_dg_)
                                      : static_cast<float>(raw.force_dg - prev_.force_dg);
    out = correct(prev_, prev_lag_, slope);
    prev2_dg_ = prev_.force_dg;
    ready = true;
  }
  prev_ = raw;
  prev_lag_ = lag;
  if (pending_ < 2) ++pending_;
  return ready;
}

bool SweepLagCorrector::finish(SweepPointV2& out) {
  if (pending_ == 0) return false;
  const float slope = pending_ >= 2 ? static_cast<float>(prev_.force_dg - prev2_dg_) : 0.0f;
  out = correct(prev_, prev_lag_, slope);
  pending_ = 0;
  return true;
}

}  // namespace tc

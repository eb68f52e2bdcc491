// The MPU-6050 model's DLPF settings measured on the chip model (sim/mpu6050_dlpf.hpp).
#include "sim/mpu6050_dlpf.hpp"

#include <cmath>
#include <numbers>

namespace sim {
namespace {

// A chip awake at DLPF_CFG cfg, +-250 deg/s and +-4 g, fed by `truth`, ticked to `until_s`.
struct Bench {
  ImuTruthSource source;
  Mpu6050 chip;
  double t_s = 0;
  Bench(int cfg, bool noise, ImuTruthSource truth) : source(std::move(truth)), chip(params(noise), source) {
    write(Mpu6050::kPwrMgmt1, 0);
    write(Mpu6050::kConfig, static_cast<uint8_t>(cfg));
    write(Mpu6050::kAccelConfig, 1 << 3);
  }
  static Mpu6050Params params(bool noise) {
    Mpu6050Params p;
    p.unit_errors = false;
    p.noise = noise;
    return p;
  }
  void write(uint8_t reg, uint8_t v) {
    chip.i2cStart(0xD0);
    chip.i2cWrite(reg);
    chip.i2cWrite(v);
    chip.i2cStop();
  }
  void tick() {
    t_s += chip.tickPeriod_s();
    chip.tick(t_s);
  }
  double gyro_dps() const { return chip.reg16(Mpu6050::kGyroXoutH) / 131.0; }
  double accel_g() const { return chip.reg16(Mpu6050::kAccelXoutH) / 8192.0; }
};

// Whether the last tick put out a new sample of the sensor asked for.
bool fresh(const Bench& b, bool gyro) {
  return (gyro ? b.chip.lastLatch_s() : b.chip.lastAccelSample_s()) == b.t_s;
}

// Gain of the chain at f_hz: a sine fitted at the sample instants over whole periods.
double gainAt(int cfg, bool gyro, double f_hz) {
  const double w = 2 * std::numbers::pi * f_hz, amp = gyro ? 100.0 : 1.0;
  Bench b(cfg, false, [&](double t) {
    ImuTruth tr;
    (gyro ? tr.rate_dps[0] : tr.specific_force_g[0]) = amp * std::sin(w * t);
    return tr;
  });
  const double settle_s = 0.2, span_s = std::ceil(0.2 * f_hz) / f_hz;
  while (b.t_s < settle_s) b.tick();
  double s = 0, c = 0;
  int n = 0;
  while (b.t_s < settle_s + span_s) {
    b.tick();
    if (!fresh(b, gyro)) continue;  // between samples the registers repeat
    const double y = gyro ? b.gyro_dps() : b.accel_g();
    s += y * std::sin(w * b.t_s);
    c += y * std::cos(w * b.t_s);
    ++n;
  }
  return 2.0 * std::hypot(s, c) / n / amp;
}

double searchMaxHz(int cfg, bool gyro) { return gyro && (cfg == 0 || cfg == 7) ? 1500.0 : 480.0; }

double bandwidthHz(int cfg, bool gyro) {
  double lo = 1.0, hi = searchMaxHz(cfg, gyro);
  if (gainAt(cfg, gyro, hi) > M_SQRT1_2) return hi;
  for (int i = 0; i < 30; ++i) {
    const double mid = std::sqrt(lo * hi);
    (gainAt(cfg, gyro, mid) > M_SQRT1_2 ? lo : hi) = mid;
  }
  return std::sqrt(lo * hi);
}

// The low-frequency delay: how far a ramp's reading lags its truth.
double delayMs(int cfg, bool gyro) {
  const double slope = gyro ? 500.0 : 2.0;
  Bench b(cfg, false, [&](double t) {
    ImuTruth tr;
    (gyro ? tr.rate_dps[0] : tr.specific_force_g[0]) = -slope * 0.2 + slope * t;
    return tr;
  });
  while (b.t_s < 0.3) b.tick();
  const double sampled_t = gyro ? b.chip.lastLatch_s() : b.chip.lastAccelSample_s();
  const double y = gyro ? b.gyro_dps() : b.accel_g();
  return (-slope * 0.2 + slope * sampled_t - y) / slope * 1e3;
}

double noiseRms(int cfg, bool gyro) {
  Bench b(cfg, true, [](double) { return ImuTruth{}; });
  double sum2 = 0;
  int n = 0;
  while (b.t_s < kDlpfNoiseSeconds) {
    b.tick();
    if (b.t_s < 0.1 || !fresh(b, gyro)) continue;
    const double y = gyro ? b.gyro_dps() : b.accel_g();
    sum2 += y * y;
    ++n;
  }
  return std::sqrt(sum2 / n);
}

}  // namespace

DlpfMeasured measureDlpf(int cfg, bool gyro) {
  DlpfMeasured m;
  m.search_max_hz = searchMaxHz(cfg, gyro);
  m.bandwidth_hz = bandwidthHz(cfg, gyro);
  m.above_search = m.bandwidth_hz >= m.search_max_hz;
  m.delay_ms = delayMs(cfg, gyro);
  m.noise_rms = noiseRms(cfg, gyro);
  return m;
}

std::vector<DlpfSetting> measureDlpfTable() {
  std::vector<DlpfSetting> rows;
  for (int cfg = 0; cfg < 7; ++cfg) {
    DlpfSetting r;
    r.cfg = cfg;
    r.gyro_table = Mpu6050::gyroDlpf(cfg);
    r.accel_table = Mpu6050::accelDlpf(cfg);
    r.gyro = measureDlpf(cfg, true);
    r.accel = measureDlpf(cfg, false);
    rows.push_back(r);
  }
  return rows;
}

}  // namespace sim

// `thrustcal sim imu`: one MPU-6050 unit's errors and the DLPF settings as the model has them,
// measured on the chip model itself (no firmware): the delay a ramp sees, the -3 dB bandwidth
// from sines, the noise at rest. The figures of docs/sim.md come from here.
#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "sim/air_cli.hpp"
#include "sim/mpu6050.hpp"

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

double bandwidthHz(int cfg, bool gyro) {
  double lo = 1.0, hi = gyro && (cfg == 0 || cfg == 7) ? 1500.0 : 480.0;
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
  while (b.t_s < 2.0) {
    b.tick();
    if (b.t_s < 0.1 || !fresh(b, gyro)) continue;
    const double y = gyro ? b.gyro_dps() : b.accel_g();
    sum2 += y * y;
    ++n;
  }
  return std::sqrt(sum2 / n);
}

void printUnit(uint64_t seed) {
  const Mpu6050Errors e = Mpu6050Errors::draw(seed);
  fmt::print("MPU-6050 unit seed {} (sigma = tolerance / 3, clamped at the tolerance):\n", seed);
  fmt::print("  gyro zero-rate offset  x {:+7.2f}  y {:+7.2f}  z {:+7.2f} deg/s   (+-20)\n",
             e.gyro_offset_dps[0], e.gyro_offset_dps[1], e.gyro_offset_dps[2]);
  fmt::print("  gyro sensitivity       x {:+7.2f}  y {:+7.2f}  z {:+7.2f} %       (+-3)\n",
             (e.gyro_scale[0] - 1) * 100, (e.gyro_scale[1] - 1) * 100, (e.gyro_scale[2] - 1) * 100);
  fmt::print("  accel zero-g offset    x {:+7.1f}  y {:+7.1f}  z {:+7.1f} mg      (+-50, +-50, +-80)\n",
             e.accel_offset_g[0] * 1e3, e.accel_offset_g[1] * 1e3, e.accel_offset_g[2] * 1e3);
  fmt::print("  accel sensitivity      x {:+7.2f}  y {:+7.2f}  z {:+7.2f} %       (+-3)\n",
             (e.accel_scale[0] - 1) * 100, (e.accel_scale[1] - 1) * 100, (e.accel_scale[2] - 1) * 100);
}

void printDlpf() {
  fmt::print("\nDLPF_CFG as modelled (+-250 deg/s, +-4 g; delay from a ramp, -3 dB from sines, noise at rest):\n");
  fmt::print("cfg | gyro: table BW / delay | model -3 dB / delay | noise rms || accel: table BW / delay | model -3 dB / delay | noise rms\n");
  for (int cfg = 0; cfg < 7; ++cfg) {
    const auto g = Mpu6050::gyroDlpf(cfg), a = Mpu6050::accelDlpf(cfg);
    fmt::print("{:>3} | {:>6.0f} Hz / {:>5.2f} ms | {:>6.1f} Hz / {:>5.2f} ms | {:.3f} deg/s || {:>6.0f} Hz / {:>5.2f} ms | "
               "{:>6.1f} Hz / {:>5.2f} ms | {:.2f} mg\n",
               cfg, g.bandwidth_hz, g.delay_s * 1e3, bandwidthHz(cfg, true), delayMs(cfg, true),
               noiseRms(cfg, true), a.bandwidth_hz, a.delay_s * 1e3, bandwidthHz(cfg, false),
               delayMs(cfg, false), noiseRms(cfg, false) * 1e3);
  }
  fmt::print("(accelerometer sampled at 1 kHz: its -3 dB point is capped by the 500 Hz Nyquist limit)\n");
}

}  // namespace

void addImuCommand(CLI::App& sim) {
  auto* cmd = sim.add_subcommand(
      "imu",
      "The simulated MPU-6050: one unit's errors (--seed) and the DLPF settings as modelled,\n"
      "measured on the chip model (delay a ramp sees, -3 dB bandwidth, noise at rest) next to\n"
      "the datasheet's table.");
  auto seed = std::make_shared<uint64_t>(1);
  auto no_table = std::make_shared<bool>(false);
  cmd->add_option("--seed", *seed, "the unit")->capture_default_str();
  cmd->add_flag("--unit-only", *no_table, "only the unit's errors, not the DLPF table");
  cmd->callback([seed, no_table] {
    printUnit(*seed);
    if (!*no_table) printDlpf();
  });
}

}  // namespace sim

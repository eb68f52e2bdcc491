// `thrustcal sim imu`: one MPU-6050 unit's errors and the DLPF settings as the model has them,
// measured on the chip model itself (sim/mpu6050_dlpf.hpp, no firmware): the delay a ramp sees,
// the -3 dB bandwidth from sines, the noise at rest (`thrustcal bench imu` puts the same figures
// in the JSON docs/sim.md's DLPF table is generated from).
#include <fmt/format.h>

#include "sim/air_cli.hpp"
#include "sim/mpu6050.hpp"
#include "sim/mpu6050_dlpf.hpp"

namespace sim {
namespace {

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
  for (const DlpfSetting& r : measureDlpfTable()) {
    const auto &g = r.gyro_table, &a = r.accel_table;
    fmt::print("{:>3} | {:>6.0f} Hz / {:>5.2f} ms | {:>6.1f} Hz / {:>5.2f} ms | {:.3f} deg/s || {:>6.0f} Hz / {:>5.2f} ms | "
               "{:>6.1f} Hz / {:>5.2f} ms | {:.2f} mg\n",
               r.cfg, g.bandwidth_hz, g.delay_s * 1e3, r.gyro.bandwidth_hz, r.gyro.delay_ms, r.gyro.noise_rms,
               a.bandwidth_hz, a.delay_s * 1e3, r.accel.bandwidth_hz, r.accel.delay_ms, r.accel.noise_rms * 1e3);
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

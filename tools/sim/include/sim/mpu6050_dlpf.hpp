// The MPU-6050 model's DLPF settings measured on the chip model itself (class Mpu6050, no
// firmware, no simavr): for each DLPF_CFG 0..6, the gyro's and the accelerometer's -3 dB
// bandwidth (sines fitted at the sample instants, bisection), the low-frequency delay a ramp
// sees and the noise rms at rest, beside the datasheet's table (Mpu6050::gyroDlpf/accelDlpf,
// the table's one home). `thrustcal sim imu` prints these; `thrustcal bench imu` puts them in
// the JSON docs/sim.md's DLPF table is generated from. The whole table takes well under a
// second.
#pragma once
#include <vector>

#include "sim/mpu6050.hpp"

namespace sim {

// One sensor at one setting, as measured (+-250 deg/s, +-4 g; truth on the x axis).
struct DlpfMeasured {
  double bandwidth_hz = 0;  // -3 dB; the search's upper end when the gain is still above it
  bool above_search = false;  // the gain at the search's upper end is above -3 dB: no cut-off
  double search_max_hz = 0;   // 1500 Hz for the 8 kHz gyro (DLPF_CFG 0), else 480 Hz (Nyquist 500)
  double delay_ms = 0;        // how far a ramp's reading lags its truth
  double noise_rms = 0;       // at rest, unit noise on: deg/s (gyro) or g (accelerometer)
};

struct DlpfSetting {
  int cfg = 0;
  Mpu6050::DlpfRow gyro_table{}, accel_table{};  // the datasheet's bandwidth and delay
  DlpfMeasured gyro, accel;
};

// The noise figures come from this many simulated seconds at rest (after 0.1 s of settling).
constexpr double kDlpfNoiseSeconds = 2.0;

DlpfMeasured measureDlpf(int cfg, bool gyro);
// DLPF_CFG 0..6 (7 is reserved: the chip treats it as 0).
std::vector<DlpfSetting> measureDlpfTable();

}  // namespace sim

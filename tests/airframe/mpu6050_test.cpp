// The MPU-6050 chip model against its register map and product specification: reset values,
// sleep, full scales, saturation, byte order, temperature, sample rate, DLPF delays, noise
// density, unit errors, one-sample bursts, faults. The chip is driven directly (its I2C slave
// calls and its sample clock), no simavr: fast and exact.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <vector>

#include "sim/mpu6050.hpp"

namespace {

using sim::ImuTruth;
using sim::Mpu6050;

struct Chip {
  ImuTruth truth;
  std::function<ImuTruth(double)> source;  // null: the constant `truth`
  Mpu6050 chip;
  double t_s = 0;
  explicit Chip(sim::Mpu6050Params p = ideal())
      : chip(p, [this](double t) { return source ? source(t) : truth; }) {}
  static sim::Mpu6050Params ideal() {
    sim::Mpu6050Params p;
    p.unit_errors = false;
    p.noise = false;
    return p;
  }
  void write(uint8_t reg, uint8_t value) {
    ASSERT_TRUE(chip.i2cStart(0xD0));
    chip.i2cWrite(reg);
    chip.i2cWrite(value);
    chip.i2cStop();
  }
  std::vector<uint8_t> read(uint8_t reg, int n) {
    chip.i2cStart(0xD0);
    chip.i2cWrite(reg);
    chip.i2cStart(0xD1);
    std::vector<uint8_t> out;
    for (int i = 0; i < n; ++i) out.push_back(chip.i2cRead(i + 1 < n));
    chip.i2cStop();
    return out;
  }
  void run(int ticks) {
    for (int i = 0; i < ticks; ++i) {
      t_s += chip.tickPeriod_s();
      chip.tick(t_s);
    }
  }
  int16_t gyroX() const { return chip.reg16(Mpu6050::kGyroXoutH); }
  int16_t accel(int axis) const { return chip.reg16(static_cast<uint8_t>(Mpu6050::kAccelXoutH + 2 * axis)); }
};

TEST(Mpu6050, PowersUpAsleepWithEveryRegisterZeroButPwrMgmt1AndWhoAmI) {
  Chip c;
  for (int r = 0; r < 128; ++r) {
    const int expected = r == 0x6B ? 0x40 : r == 0x75 ? 0x68 : 0;
    EXPECT_EQ(c.chip.reg(static_cast<uint8_t>(r)), expected) << fmt::format("register 0x{:02X}", r);
  }
  EXPECT_EQ(c.read(0x75, 1).at(0), 0x68);
}

TEST(Mpu6050, DataRegistersDoNotChangeWhileAsleep) {
  Chip c;
  c.truth.rate_dps = {100, 0, 0};
  c.run(50);
  EXPECT_EQ(c.gyroX(), 0);
  EXPECT_EQ(c.chip.updates(), 0u);
  c.write(0x6B, 0x00);
  c.run(5);
  EXPECT_EQ(c.gyroX(), 13100);
  c.write(0x6B, 0x40);  // back to sleep: the last sample stays
  c.truth.rate_dps = {-50, 0, 0};
  c.run(20);
  EXPECT_EQ(c.gyroX(), 13100);
}

struct ScaleCase {
  int fs_sel;
  double gyro_lsb_per_dps;
  double accel_lsb_per_g;
};

class Mpu6050Scale : public ::testing::TestWithParam<ScaleCase> {};

TEST_P(Mpu6050Scale, FullScaleSettingsGiveTheDatasheetSensitivity) {
  const auto s = GetParam();
  Chip c;
  c.write(0x6B, 0x00);
  c.write(0x1B, static_cast<uint8_t>(s.fs_sel << 3));
  c.write(0x1C, static_cast<uint8_t>(s.fs_sel << 3));
  c.truth.rate_dps = {100, -40, 7.5};
  c.truth.specific_force_g = {0.25, -0.5, 1.0};
  c.run(30);
  const double g[3] = {100, -40, 7.5}, a[3] = {0.25, -0.5, 1.0};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(c.chip.reg16(static_cast<uint8_t>(0x43 + 2 * i)), std::lround(g[i] * s.gyro_lsb_per_dps)) << i;
    EXPECT_EQ(c.accel(i), std::lround(a[i] * s.accel_lsb_per_g)) << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Datasheet, Mpu6050Scale,
                         ::testing::Values(ScaleCase{0, 131.0, 16384.0}, ScaleCase{1, 65.5, 8192.0},
                                           ScaleCase{2, 32.8, 4096.0}, ScaleCase{3, 16.4, 2048.0}),
                         [](const auto& info) { return fmt::format("fs_sel{}", info.param.fs_sel); });

TEST(Mpu6050, ValuesAreBigEndianTwosComplementAndSaturate) {
  Chip c;
  c.write(0x6B, 0x00);
  c.truth.rate_dps = {300, -300, 0};     // beyond +-250 deg/s
  c.truth.specific_force_g = {-1, 0, 1};
  c.run(30);
  const auto b = c.read(0x3B, 14);
  EXPECT_EQ(b[0], 0xC0);  // -1 g = -16384 = 0xC000
  EXPECT_EQ(b[1], 0x00);
  EXPECT_EQ(b[4], 0x40);  // +1 g
  EXPECT_EQ(b[8], 0x7F);  // +32767
  EXPECT_EQ(b[9], 0xFF);
  EXPECT_EQ(b[10], 0x80);  // -32768
  EXPECT_EQ(b[11], 0x00);
}

TEST(Mpu6050, TemperatureIsRawOver340Plus36_53) {
  Chip c;
  c.write(0x6B, 0x00);
  c.truth.temp_c = 25.0;
  c.run(3);
  const int16_t raw = c.chip.reg16(Mpu6050::kTempOutH);
  EXPECT_EQ(raw, std::lround((25.0 - 36.53) * 340.0));
  EXPECT_NEAR(raw / 340.0 + 36.53, 25.0, 0.5 / 340.0);
}

struct RateCase {
  int dlpf_cfg;
  int smplrt_div;
  double rate_hz;
};

class Mpu6050SampleRate : public ::testing::TestWithParam<RateCase> {};

TEST_P(Mpu6050SampleRate, DataUpdatesAtGyroRateOverOnePlusDivider) {
  const auto r = GetParam();
  Chip c;
  c.write(0x6B, 0x00);
  c.write(0x1A, static_cast<uint8_t>(r.dlpf_cfg));
  c.write(0x19, static_cast<uint8_t>(r.smplrt_div));
  const uint64_t before = c.chip.updates();
  const int ticks = static_cast<int>(std::lround(0.5 / c.chip.tickPeriod_s()));  // 0.5 s
  c.run(ticks);
  EXPECT_EQ(c.chip.updates() - before, static_cast<uint64_t>(std::lround(0.5 * r.rate_hz)));
  EXPECT_DOUBLE_EQ(c.chip.sampleRate_hz(), r.rate_hz);
}

INSTANTIATE_TEST_SUITE_P(Datasheet, Mpu6050SampleRate,
                         ::testing::Values(RateCase{0, 0, 8000}, RateCase{0, 7, 1000},
                                           RateCase{3, 0, 1000}, RateCase{3, 4, 200},
                                           RateCase{6, 9, 100}, RateCase{7, 1, 4000}),
                         [](const auto& info) {
                           return fmt::format("dlpf{}_div{}", info.param.dlpf_cfg, info.param.smplrt_div);
                         });

// The group delay a ramp sees: the reading lags the truth by the filter's low-frequency delay.
class Mpu6050Dlpf : public ::testing::TestWithParam<int> {};

TEST_P(Mpu6050Dlpf, RampLagsByTheDatasheetDelay) {
  const int cfg = GetParam();
  Chip c;
  c.write(0x6B, 0x00);
  c.write(0x1A, static_cast<uint8_t>(cfg));
  const double gyro_slope = 500.0, accel_slope = 2.0;  // deg/s per s, g per s
  c.source = [&](double t) {
    ImuTruth tr;
    tr.rate_dps = {-100.0 + gyro_slope * t, 0, 0};
    tr.specific_force_g = {-0.8 + accel_slope * t, 0, 1};
    return tr;
  };
  // when: 0.3 s of ramp (far past every filter's settling)
  c.run(static_cast<int>(std::lround(0.3 / c.chip.tickPeriod_s())));
  // then: at the instants the registers' samples were taken, truth - reading = slope * delay
  const double tg = c.chip.lastLatch_s(), t = c.chip.lastAccelSample_s();
  const double gyro_lag_s = (-100.0 + gyro_slope * tg - c.gyroX() / 131.0) / gyro_slope;
  const double accel_lag_s = (-0.8 + accel_slope * t - c.accel(0) / 16384.0) / accel_slope;
  EXPECT_NEAR(gyro_lag_s, Mpu6050::gyroDlpf(cfg).delay_s, 0.03e-3) << "gyro, DLPF_CFG " << cfg;
  EXPECT_NEAR(accel_lag_s, Mpu6050::accelDlpf(cfg).delay_s, 0.05e-3) << "accel, DLPF_CFG " << cfg;
  RecordProperty("gyro_delay_ms", fmt::format("{:.3f}", gyro_lag_s * 1e3));
  RecordProperty("accel_delay_ms", fmt::format("{:.3f}", accel_lag_s * 1e3));
}

INSTANTIATE_TEST_SUITE_P(Datasheet, Mpu6050Dlpf, ::testing::Range(0, 7),
                         [](const auto& info) { return fmt::format("cfg{}", info.param); });

TEST(Mpu6050, DlpfTableIsTheDatasheets) {
  const double gyro[7][2] = {{256, 0.98}, {188, 1.9}, {98, 2.8}, {42, 4.8}, {20, 8.3}, {10, 13.4}, {5, 18.6}};
  const double accel[7][2] = {{260, 0.0}, {184, 2.0}, {94, 3.0}, {44, 4.9}, {21, 8.5}, {10, 13.8}, {5, 19.0}};
  for (int cfg = 0; cfg < 7; ++cfg) {
    EXPECT_EQ(Mpu6050::gyroDlpf(cfg).bandwidth_hz, gyro[cfg][0]);
    EXPECT_DOUBLE_EQ(Mpu6050::gyroDlpf(cfg).delay_s * 1e3, gyro[cfg][1]);
    EXPECT_EQ(Mpu6050::accelDlpf(cfg).bandwidth_hz, accel[cfg][0]);
    EXPECT_DOUBLE_EQ(Mpu6050::accelDlpf(cfg).delay_s * 1e3, accel[cfg][1]);
  }
}

TEST(Mpu6050, NoiseHasTheDatasheetDensityAtLowFrequency) {
  // The mean over a block of L seconds of white noise of density rho (one-sided) has variance
  // rho^2 / (2 L), whatever the DLPF does above 1/L.
  sim::Mpu6050Params p;
  p.unit_errors = false;
  p.seed = 11;
  Chip c(p);
  c.write(0x6B, 0x00);
  c.write(0x1A, 0x03);
  const int blocks = 400, per_block = 100;  // 0.1 s at 1 kHz
  c.run(400);
  double gsum2 = 0, asum2 = 0;
  for (int b = 0; b < blocks; ++b) {
    double g = 0, a = 0;
    for (int i = 0; i < per_block; ++i) {
      c.run(8);  // one 1 kHz sample
      g += c.gyroX() / 131.0;
      a += c.accel(1) / 16384.0;
    }
    gsum2 += (g / per_block) * (g / per_block);
    asum2 += (a / per_block) * (a / per_block);
  }
  const double gyro_density = std::sqrt(gsum2 / blocks * 2 * 0.1);
  const double accel_density = std::sqrt(asum2 / blocks * 2 * 0.1);
  EXPECT_NEAR(gyro_density, 0.005, 0.005 * 0.12);     // deg/s/rtHz
  EXPECT_NEAR(accel_density, 400e-6, 400e-6 * 0.12);  // g/rtHz
}

TEST(Mpu6050, UnitErrorsAreSeededAndWithinTheDatasheetTolerances) {
  const auto a = sim::Mpu6050Errors::draw(7), b = sim::Mpu6050Errors::draw(7), d = sim::Mpu6050Errors::draw(8);
  EXPECT_EQ(a.gyro_offset_dps, b.gyro_offset_dps);
  EXPECT_EQ(a.accel_scale, b.accel_scale);
  EXPECT_NE(a.gyro_offset_dps, d.gyro_offset_dps);
  double max_offset = 0;
  for (uint64_t seed = 1; seed <= 300; ++seed) {
    const auto e = sim::Mpu6050Errors::draw(seed);
    for (int i = 0; i < 3; ++i) {
      EXPECT_LE(std::abs(e.gyro_offset_dps[i]), 20.0 + 1e-12);
      EXPECT_LE(std::abs(e.accel_offset_g[i]), (i == 2 ? 0.080 : 0.050) + 1e-12);
      EXPECT_LE(std::abs(e.gyro_scale[i] - 1), 0.03 + 1e-12);
      EXPECT_LE(std::abs(e.accel_scale[i] - 1), 0.03 + 1e-12);
      for (int j = 0; j < 3; ++j) EXPECT_LE(std::abs(e.gyro_cross[i][j]), 0.02 + 1e-12);
      max_offset = std::max(max_offset, std::abs(e.gyro_offset_dps[i]));
    }
  }
  EXPECT_GT(max_offset, 10.0) << "the spread should use the tolerance, not a sliver of it";
}

TEST(Mpu6050, AUnitAtRestReadsItsOwnOffsets) {
  sim::Mpu6050Params p;
  p.noise = false;
  p.seed = 3;
  Chip c(p);
  c.write(0x6B, 0x00);
  c.run(30);
  const auto& e = c.chip.errors();
  EXPECT_NEAR(c.gyroX(), e.gyro_offset_dps[0] * 131.0, 1.0);
  EXPECT_NEAR(c.accel(2), (e.accel_scale[2] * 1.0 + e.accel_offset_g[2]) * 16384.0, 1.0);
}

TEST(Mpu6050, ABurstReadReturnsOneSampleEvenWhenSamplesArriveDuringIt) {
  Chip c;
  c.write(0x6B, 0x00);
  c.source = [](double t) {
    ImuTruth tr;
    tr.rate_dps = {1000 * t, -1000 * t, 0};
    tr.specific_force_g = {t, 0, 1};
    return tr;
  };
  c.run(10);
  const auto snapshot = c.read(0x3B, 14);
  // when: the master reads half the burst, two samples are taken, then it reads the rest
  c.chip.i2cStart(0xD0);
  c.chip.i2cWrite(0x3B);
  c.chip.i2cStart(0xD1);
  std::vector<uint8_t> got;
  for (int i = 0; i < 7; ++i) got.push_back(c.chip.i2cRead(true));
  c.run(2);
  for (int i = 7; i < 14; ++i) got.push_back(c.chip.i2cRead(i < 13));
  c.chip.i2cStop();
  // then: the 14 bytes are the sample of the burst's start; after the STOP the next one shows
  EXPECT_EQ(got, snapshot);
  EXPECT_NE(c.read(0x3B, 14), snapshot);
}

TEST(Mpu6050, DataReadyIsSetBySamplesAndClearedByReadingIntStatus) {
  Chip c;
  c.write(0x6B, 0x00);
  c.run(1);
  EXPECT_EQ(c.read(0x3A, 1).at(0) & 1, 1);
  EXPECT_EQ(c.read(0x3A, 1).at(0) & 1, 0);
}

TEST(Mpu6050, DeviceResetRestoresThePowerUpRegisters) {
  Chip c;
  c.write(0x6B, 0x00);
  c.write(0x1B, 0x18);
  c.write(0x6B, 0x80);
  EXPECT_EQ(c.chip.reg(0x6B), 0x40);
  EXPECT_EQ(c.chip.reg(0x1B), 0x00);
}

TEST(Mpu6050, WhoAmIAndDataRegistersAreReadOnly) {
  Chip c;
  c.write(0x75, 0x12);
  c.write(0x3B, 0x34);
  EXPECT_EQ(c.chip.reg(0x75), 0x68);
  EXPECT_EQ(c.chip.reg(0x3B), 0x00);
}

TEST(Mpu6050, FaultsNackTheAddressOrFreezeTheData) {
  Chip c;
  c.write(0x6B, 0x00);
  c.run(2);
  c.chip.setNack(true);
  EXPECT_FALSE(c.chip.i2cStart(0xD0));
  c.chip.setNack(false);
  c.chip.setFrozen(true);
  const uint64_t n = c.chip.updates();
  c.truth.rate_dps = {50, 0, 0};
  c.run(10);
  EXPECT_EQ(c.chip.updates(), n);
  EXPECT_EQ(c.gyroX(), 0);
}

}  // namespace

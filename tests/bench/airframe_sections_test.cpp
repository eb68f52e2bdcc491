// Benchmarks 11 and 12 (tools/bench/src/sections_airframe.cpp), whose JSON docs/sim.md's TWI and
// DLPF tables are generated from: the structure the docs' blocks read, and the targets. A TWI
// whose bit time lost its prescaler term or its ninth (ACK) bit, or a driver that spins far
// longer per operation, fails the TWI test; a DLPF whose delay line or bandwidth moved away from
// the datasheet's table fails the IMU one. About a second of simulation in all.
#include <gtest/gtest.h>

#include <string>

#include "bench/sections.hpp"

namespace {

TEST(BenchTwiSection, EveryReadTakesTheDatasheetsBusTimeAndTheDriversStayWithinTheirBound) {
  const bench::Section s = bench::twiSection();
  ASSERT_EQ(s.key, "twi");
  if (s.json.contains("available")) GTEST_SKIP() << s.json["reason"].get<std::string>();
  const nlohmann::json& rows = s.json["rows"];
  ASSERT_EQ(rows.size(), 6u);  // burst and one register at 400 kHz, 100 kHz, 100 kHz via TWPS 1
  for (const auto& r : rows) {
    SCOPED_TRACE(r.dump());
    const int bytes = r["bytes"].get<int>();
    const uint64_t twbr = r["twbr"], twps = r["twps"];
    const uint64_t bit = 16 + 2 * twbr * (1ull << (2 * twps));
    // SLA+W, register, SLA+R and the data, 9 bits each; START, repeated START, STOP 1 bit each
    EXPECT_EQ(r["bus_cycles_hand"].get<uint64_t>(), static_cast<uint64_t>((3 + bytes) * 9 + 3) * bit);
    EXPECT_EQ(r["bus_cycles_model"].get<uint64_t>(), r["bus_cycles_hand"].get<uint64_t>());
    for (const char* driver : {"polled_cycles", "interrupt_cycles"})
      EXPECT_GT(r[driver].get<uint64_t>(), r["bus_cycles_model"].get<uint64_t>()) << driver;
    for (const char* per_op : {"polled_software_cycles_per_op", "interrupt_software_cycles_per_op"}) {
      EXPECT_GT(r[per_op].get<double>(), 20.0) << per_op;  // a driver is never free
      EXPECT_LE(r[per_op].get<double>(), 120.0) << per_op;
    }
  }
  EXPECT_EQ(rows[0]["scl_hz"].get<uint32_t>(), 400000u);
  EXPECT_EQ(rows[0]["bus_cycles_model"].get<uint64_t>(), 6240u);   // 156 bits of 40 cycles
  EXPECT_EQ(rows[2]["bus_cycles_model"].get<uint64_t>(), 24960u);  // 156 bits of 160 cycles
  EXPECT_EQ(rows[4]["bus_cycles_model"].get<uint64_t>(), rows[2]["bus_cycles_model"].get<uint64_t>());
  ASSERT_EQ(s.targets.size(), 2u);
  for (const auto& t : s.targets) EXPECT_TRUE(t.met) << t.what << ": " << t.figure;
  ASSERT_EQ(s.tables.size(), 1u);
}

TEST(BenchImuSection, TheModelsDlpfDelaysAreTheDatasheetsAndItsBandwidthsFollowTheTable) {
  const bench::Section s = bench::imuSection();
  ASSERT_EQ(s.key, "imu");
  if (s.json.contains("available")) GTEST_SKIP() << s.json["reason"].get<std::string>();
  const nlohmann::json& rows = s.json["dlpf"];
  ASSERT_EQ(rows.size(), 7u);  // DLPF_CFG 0..6
  double last_gyro_noise = 1e9;
  for (const auto& r : rows) {
    SCOPED_TRACE(r.dump());
    for (const char* sensor : {"gyro", "accel"}) {
      const auto& m = r[sensor];
      EXPECT_NEAR(m["delay_ms"].get<double>(), m["table_delay_ms"].get<double>(), 0.05) << sensor;
      EXPECT_GT(m["noise_rms"].get<double>(), 0.0) << sensor;
      EXPECT_GT(m["table_bandwidth_hz"].get<double>(), 0.0) << sensor;
    }
    const auto& g = r["gyro"];
    ASSERT_TRUE(g.contains("bandwidth_hz"));  // the gyro always has a -3 dB point below 1.5 kHz
    const double pct = g["bandwidth_pct_of_table"].get<double>();
    if (g["widened"].get<bool>())
      EXPECT_GE(pct, 100.0);
    else
      EXPECT_NEAR(pct, 100.0, 10.0);
    // a narrower filter lets less noise through
    EXPECT_LT(g["noise_rms"].get<double>(), last_gyro_noise);
    last_gyro_noise = g["noise_rms"].get<double>();
  }
  EXPECT_TRUE(rows[0]["accel"]["unfiltered"].get<bool>());  // DLPF_CFG 0: no accelerometer filter
  EXPECT_EQ(rows[0]["gyro"]["table_bandwidth_hz"].get<double>(), 256.0);  // the datasheet's
  EXPECT_FALSE(rows[4]["gyro"]["widened"].get<bool>());
  EXPECT_TRUE(rows[5]["gyro"]["widened"].get<bool>());
  ASSERT_EQ(s.targets.size(), 2u);
  for (const auto& t : s.targets) EXPECT_TRUE(t.met) << t.what << ": " << t.figure;
  ASSERT_EQ(s.tables.size(), 1u);
}

}  // namespace

// The simulated board's TWI against the ATmega2560 datasheet (ch. 24), with the air_probe image
// and the MPU-6050 part on the bus: the status sequence of a polled and of an interrupt-driven
// register read, NACKs, TWWC, and the bus timing from TWBR/TWPS.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <string>

#include "air_support.hpp"
#include "sim/twi.hpp"
#include "text_match.hpp"

namespace {

using air::TwiProbe;

TEST_F(TwiProbe, PolledRegisterReadShowsTheChipsStatusSequence) {
  // given: the IMU awake
  wake();
  // when: WHO_AM_I is read the way a polled driver does (START, SLA+W, register, repeated
  // START, SLA+R, one byte answered with NACK, STOP)
  const auto r = command("rd 117 1");
  // then: 08 18 28 10 40 58, the byte 0x68, and the driver spun while TWINT was clear
  ASSERT_EQ(r.size(), 2u) << console->tail();
  EXPECT_TRUE(tc::test::Pattern(R"(st 08 18 28 10 40 58 cyc \d+ data 68)").matches(r[0])) << r[0];
  const int spins = std::stoi(r[1].substr(5));
  EXPECT_GT(spins, 0) << "TWINT read as set right after it was cleared (simavr 1.6's bug)";
}

TEST_F(TwiProbe, BurstReadAcknowledgesEveryByteButTheLast) {
  wake();
  const auto r = command("rd 59 14");
  std::string expected = "st 08 18 28 10 40";
  for (int i = 0; i < 13; ++i) expected += " 50";
  expected += " 58 cyc";
  EXPECT_EQ(r.at(0).rfind(expected, 0), 0u) << r.at(0);
}

TEST_F(TwiProbe, InterruptDrivenReadSeesTheSameSequenceFromTheTwiVector) {
  wake();
  const auto r = command("ri 117 2");
  ASSERT_FALSE(r.empty());
  EXPECT_TRUE(tc::test::Pattern(R"(st 08 18 28 10 40 50 58 cyc \d+ data 68 00)").matches(r[0])) << r[0];
}

TEST_F(TwiProbe, AnAbsentSlaveNacksItsAddressWith0x20) {
  command("addr 105");
  const auto r = command("rd 117 1");
  EXPECT_EQ(r.at(0).rfind("st 08 20 cyc", 0), 0u) << r.at(0);
}

TEST_F(TwiProbe, WritingTwdrWhileAByteShiftsSetsTwwc) {
  const auto r = command("wc");
  EXPECT_EQ(r.at(0), "twwc 1");
}

TEST_F(TwiProbe, WritesReachTheImuAndReadBack) {
  wake();
  command("wr 27 24");  // GYRO_CONFIG: FS_SEL 3 (+-2000 deg/s)
  EXPECT_EQ(imu->chip().reg(0x1B), 24);
  const auto r = command("rd 27 1");
  EXPECT_NE(r.at(0).find("data 18"), std::string::npos) << r.at(0);
}

struct TwiRateCase {
  int twbr;
  int twps;
  uint64_t bit_cycles;  // 16 + 2 TWBR 4^TWPS (datasheet 24.5.2)
};

class TwiTiming : public TwiProbe, public ::testing::WithParamInterface<TwiRateCase> {};

TEST_P(TwiTiming, EveryByteTakesNineBitsOf16Plus2TwbrTimes4PowTwps) {
  // given
  const TwiRateCase c = GetParam();
  wake();
  command(fmt::format("rate {} {}", c.twbr, c.twps));
  ASSERT_EQ(board->twi().bitCycles(), c.bit_cycles);
  for (const char* driver : {"rd", "ri"}) {  // polled, interrupt-driven
    SCOPED_TRACE(driver);
    board->twi().clearTrace();
    board->twi().setTracing(true);
    // when: a 14-byte burst
    const auto r = command(fmt::format("{} 59 14", driver));
    board->twi().setTracing(false);
    // then: each operation lasts one bit (conditions) or nine (a byte and its acknowledge)
    const auto& trace = board->twi().trace();
    int bytes = 0, conditions = 0;
    for (std::size_t i = 0; i + 1 < trace.size(); ++i) {
      if (trace[i].what != sim::TwiEvent::What::kOpStart) continue;
      ASSERT_EQ(trace[i + 1].what, sim::TwiEvent::What::kStatus);
      const uint64_t took = trace[i + 1].cycle - trace[i].cycle;
      const auto op = static_cast<sim::TwiOp>(trace[i].value);
      const bool byte = op == sim::TwiOp::kAddress || op == sim::TwiOp::kWrite || op == sim::TwiOp::kRead;
      EXPECT_EQ(took, (byte ? 9 : 1) * c.bit_cycles) << "operation " << i;
      (byte ? bytes : conditions) += 1;
    }
    EXPECT_EQ(bytes, 2 + 1 + 14);  // SLA+W, register, SLA+R, 14 data bytes
    EXPECT_EQ(conditions, 3);      // START, repeated START, STOP
    // and the firmware's own count: the bus time plus a little software per operation
    tc::test::Groups m;
    ASSERT_TRUE(tc::test::Pattern(R"(cyc (\d+))").foundIn(r.at(0), &m));
    const uint64_t bus = (17 * 9 + 3) * c.bit_cycles;
    const uint64_t measured = std::stoull(m[1]);
    EXPECT_GE(measured, bus);
    EXPECT_LE(measured, bus + 20 * 120) << "software overhead per operation too large";
    std::printf("14-byte burst (%s) at TWBR %d TWPS %d: %llu cycles (bus alone %llu)\n", driver, c.twbr,
                c.twps, static_cast<unsigned long long>(measured), static_cast<unsigned long long>(bus));
  }
}

INSTANTIATE_TEST_SUITE_P(Datasheet, TwiTiming,
                         ::testing::Values(TwiRateCase{12, 0, 40}, TwiRateCase{72, 0, 160},
                                           TwiRateCase{18, 1, 160}),
                         [](const auto& info) {
                           return fmt::format("twbr{}_twps{}", info.param.twbr, info.param.twps);
                         });

}  // namespace

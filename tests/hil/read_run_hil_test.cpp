// read_run.elf, unchanged, in simavr: on the tethered quad (four varied motors, one LiPo) and
// on the bench, with an EEPROM calibrated by the real gather_store (hil::fleetEeprom()).
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "hil_support.hpp"
#include "sim/console.hpp"
#include "sim/rigs.hpp"
#include "text_match.hpp"
#include "thrustcal/eeprom_codec.hpp"

namespace {

using hil::imagePath;

std::array<plant::ActuatorParams, 4> fleetMotors() {
  std::array<plant::ActuatorParams, 4> m;
  for (int i = 0; i < 4; ++i) m[i] = sim::motorForSeed("kv1100_9x4.7", hil::kFleetSeeds[i], 0.03);
  return m;
}

class ReadRunQuad : public ::testing::Test {
 protected:
  void boot(const std::vector<uint8_t>& eeprom) {
    rig = std::make_unique<sim::QuadRig>(imagePath("read_run"), plant::QuadFrameParams{},
                                         fleetMotors());
    rig->board.setEeprom(eeprom);
    con = std::make_unique<sim::Console>(rig->board, "rr> ");
    report = sim::bootReadRun(*con);
  }
  // Sends an empty line (read_run's keep-alive) every `every_s` for `seconds`, averaging the
  // plant's thrust per motor over the last `average_s`.
  std::array<double, 4> holdAndAverage(double seconds, double average_s, double every_s = 0.2) {
    std::array<double, 4> sum{};
    int n = 0;
    const double t_end = rig->board.timeS() + seconds;
    while (rig->board.timeS() < t_end) {
      con->send("");
      for (int k = 0; k < static_cast<int>(every_s / 0.01); ++k) {
        rig->board.runFor(0.01);
        if (rig->board.timeS() > t_end - average_s) {
          const auto st = rig->quad.state();
          for (int i = 0; i < 4; ++i) sum[i] += st.thrust_g[i];
          ++n;
        }
      }
    }
    for (auto& s : sum) s /= std::max(n, 1);
    return sum;
  }
  std::unique_ptr<sim::QuadRig> rig;
  std::unique_ptr<sim::Console> con;
  std::vector<std::string> report;
};

struct MotorCommand {
  int motor;
  int grams;
};

void PrintTo(const MotorCommand& c, std::ostream* os) { *os << "f " << c.motor << " " << c.grams; }

class ReadRunCommands : public ReadRunQuad, public ::testing::WithParamInterface<MotorCommand> {};

// Tolerance 4 %: the stored curve (<= 4 g), the 1 us PWM grid and the sag compensation.
// Measured: 150 -> 150.0, 300 -> 298.5, 100 -> 99.8 g. Above ~380 g the 10 V curve is shaped
// by the bench supply's 6.32 A limit and option 2.1 falls 3-4 % short (400 -> 385 g).
TEST_P(ReadRunCommands, OnlyTheCommandedMotorProducesTheCommandedForce) {
  HIL_REQUIRE_IMAGE("read_run");
  HIL_REQUIRE_IMAGE("gather_store");
  // given
  boot(hil::fleetEeprom());
  const auto c = GetParam();
  // when
  const auto lines = con->command(fmt::format("f {} {}", c.motor, c.grams));
  for (const auto& l : lines) EXPECT_NE(l.rfind("error:", 0), 0u) << l;
  const auto thrust = holdAndAverage(3.0, 1.0);
  // then
  for (int i = 0; i < 4; ++i) {
    if (i == c.motor) {
      EXPECT_NEAR(thrust[i], c.grams, 0.04 * c.grams) << "motor " << i;
      EXPECT_GT(rig->board.escPulseUs(i), 1100.0);
    } else {
      EXPECT_LT(thrust[i], 1.0) << "motor " << i << " was not commanded";
      EXPECT_NEAR(rig->board.escPulseUs(i), 1000.0, 1.0) << "motor " << i;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Table, ReadRunCommands,
                         ::testing::Values(MotorCommand{0, 150}, MotorCommand{1, 300},
                                           MotorCommand{2, 350}, MotorCommand{3, 100}),
                         [](const ::testing::TestParamInfo<MotorCommand>& info) {
                           return fmt::format("motor{}_{}g", info.param.motor, info.param.grams);
                         });

TEST_F(ReadRunQuad, FailsafeStopsEveryMotorHalfASecondAfterTheLastLine) {
  HIL_REQUIRE_IMAGE("read_run");
  HIL_REQUIRE_IMAGE("gather_store");
  // given: all four running
  boot(hil::fleetEeprom());
  con->command("f 200");
  holdAndAverage(1.0, 0.1);
  con->send("");  // the last line (an empty line is a keep-alive; read_run answers nothing)
  rig->board.runFor(0.001);  // its "\r" arrives within one character time (87 us)
  const double t_last = rig->board.timeS();
  // when: silence
  con->expect("failsafe", 2.0);
  const double t_trip = rig->board.timeS();
  // then: it trips 500 ms after the last line (plus at most one 20 ms ESC frame and the 1 ms
  // check granularity), and every ESC is back at 1000 us
  EXPECT_GE(t_trip - t_last, 0.498);
  EXPECT_LE(t_trip - t_last, 0.53);
  rig->board.runFor(0.05);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(rig->board.escPulseUs(i), 1000.0, 1.0) << i;
}

TEST_F(ReadRunQuad, KeepAliveLinesHoldOffTheFailsafe) {
  HIL_REQUIRE_IMAGE("read_run");
  HIL_REQUIRE_IMAGE("gather_store");
  boot(hil::fleetEeprom());
  con->command("f 200");
  const auto thrust = holdAndAverage(3.0, 0.5, 0.4);  // a line every 400 ms
  EXPECT_EQ(rig->board.output().find("failsafe"), std::string::npos);
  for (int i = 0; i < 4; ++i) EXPECT_GT(thrust[i], 150.0) << i;
}

TEST_F(ReadRunQuad, ErasedOrCorruptRecordKeepsThatMotorDisarmed) {
  HIL_REQUIRE_IMAGE("read_run");
  HIL_REQUIRE_IMAGE("gather_store");
  // given: slot 2 erased, one byte of slot 3's first curve flipped (CRC no longer matches)
  auto eeprom = hil::fleetEeprom();
  eeprom[tc::slotAddress(2)] = 0xFF;
  eeprom[tc::slotAddress(3) + 100] ^= 0x04;
  boot(eeprom);
  // then the boot report names both
  const std::string all = ::testing::PrintToString(report);
  EXPECT_TRUE(tc::test::Pattern("motor 2[^\"]*erased").foundIn(all)) << all;
  EXPECT_TRUE(tc::test::Pattern("motor 3[^\"]*(corrupt|CRC)").foundIn(all)) << all;
  // when all motors are commanded, and motor 3 alone
  con->command("f 250");
  const auto per_motor = con->command("f 3 100");
  const auto thrust = holdAndAverage(2.0, 0.5);
  // then only the good ones spin; the refusal is an error line
  ASSERT_FALSE(per_motor.empty());
  EXPECT_EQ(per_motor[0].rfind("error:", 0), 0u) << per_motor[0];
  EXPECT_GT(thrust[0], 200.0);
  EXPECT_GT(thrust[1], 200.0);
  for (int i : {2, 3}) {
    EXPECT_LT(thrust[i], 1.0) << i;
    EXPECT_NEAR(rig->board.escPulseUs(i), 1000.0, 1.0) << i;
  }
}

TEST(ReadRunLiftoff, CalibratedSpreadIsAtLeastFiveTimesSmallerThanUncalibrated) {
  HIL_REQUIRE_IMAGE("read_run");
  HIL_REQUIRE_IMAGE("gather_store");
  // given: the fleet calibrated, tethered, full pack
  sim::LiftoffOptions o;
  o.elf_path = imagePath("read_run");
  o.eeprom = hil::fleetEeprom();
  o.seeds = hil::kFleetSeeds;
  o.progress = [](const std::string&) {};
  // when
  const sim::LiftoffResult cal = sim::runLiftoff(o);
  o.uncalibrated = true;  // slot 0's record in all four slots: the same PWM everywhere
  const sim::LiftoffResult uncal = sim::runLiftoff(o);
  // then
  EXPECT_LE(cal.thrust_spread_pct * 5.0, uncal.thrust_spread_pct)
      << "calibrated " << cal.thrust_spread_pct << " %, uncalibrated " << uncal.thrust_spread_pct
      << " %";
  EXPECT_LT(cal.force_error_rms_pct, 3.0);
  EXPECT_LT(cal.max_tilt_deg, uncal.max_tilt_deg);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(uncal.hold_pwm_us[i], uncal.hold_pwm_us[0], 1.0) << "same PWM on all four";
  }
}

// The pack drains from full to 20 %: read_run's battery compensation (option 2.1 between the
// LiPo curve and the 10 V curve, plus the sag offsets) keeps one motor on the bench within
// 4 % of 300 g.
class BatteryCompensation : public ::testing::TestWithParam<double> {};

TEST_P(BatteryCompensation, HoldsThreeHundredGramsWithinFourPercent) {
  HIL_REQUIRE_IMAGE("read_run");
  HIL_REQUIRE_IMAGE("gather_store");
  // given: motor seed 11 (slot 0) on the bench, pack at the given charge
  plant::BenchParams p = plant::BenchParams::thesis();
  p.actuator = sim::motorForSeed("kv1100_9x4.7", hil::kFleetSeeds[0], 0.03);
  p.power = plant::BatteryParams::lipo3s(GetParam());
  sim::BenchRig rig(imagePath("read_run"), p, 0);
  rig.board.setEeprom(hil::fleetEeprom());
  sim::Console con(rig.board, "rr> ");
  sim::bootReadRun(con);
  // when
  con.command("f 0 300");
  double sum = 0;
  int n = 0;
  for (int k = 0; k < 20; ++k) {  // 4 s, a line every 200 ms
    con.send("");
    rig.board.runFor(0.2);
    if (k >= 15) {
      sum += rig.bench.actuator().thrust_g();
      ++n;
    }
  }
  // then
  EXPECT_NEAR(sum / n, 300.0, 12.0) << "pack at " << GetParam() * 100 << " %, bus "
                                    << rig.bench.busVoltage_v() << " V";
}

INSTANTIATE_TEST_SUITE_P(Table, BatteryCompensation, ::testing::Values(1.0, 0.7, 0.4, 0.2),
                         [](const ::testing::TestParamInfo<double>& info) {
                           return fmt::format("charge{:.0f}pct", info.param * 100);
                         });

}  // namespace

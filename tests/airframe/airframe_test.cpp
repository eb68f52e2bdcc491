// The virtual airframe with firmware in the loop: air_probe and imu_example on the seesaw and
// the gimbal, the MPU-6050 measuring the rig, one HIL test per fault (what firmware sees when
// it happens), a board reset, determinism, the truth log, `--fault` parsing and `sim run`.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "air_support.hpp"
#include "sim/air_cli.hpp"
#include "sim/airframe.hpp"
#include "sim/twi.hpp"

extern "C" {
#include <simavr/avr_twi.h>
#include <simavr/sim_irq.h>
}

namespace {

constexpr double kLsbPerDps = 131.0;

class Airframe : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string(AIR_PROBE_ELF).empty()) GTEST_SKIP() << "avr-gcc not found: no test images";
  }
  // The probe on a rig; perfect motors (no variation) and a perfect IMU unless changed.
  void make(sim::AirframeOptions o, const std::string& elf = AIR_PROBE_ELF) {
    rig = std::make_unique<sim::AirframeRig>(elf, o);
    con = std::make_unique<sim::Console>(rig->board(), "a> ");
    if (elf == AIR_PROBE_ELF) con->waitPrompt(0.1);
  }
  static sim::AirframeOptions options(sim::AirRig which) {
    sim::AirframeOptions o;
    o.rig = which;
    o.imu_params = air::idealImu();
    return o;
  }
  std::vector<std::string> cmd(const std::string& line) { return con->command(line, 0.5); }
  void runTo(double t_s) { rig->board().runFor(t_s - rig->board().timeS()); }
  // The probe's "imu" line: ax ay az temp gx gy gz (raw).
  std::array<int, 7> imu() {
    const auto r = cmd("imu");
    std::array<int, 7> v{};
    EXPECT_EQ(r.size(), 1u);
    std::istringstream in(r.at(0));
    std::string word;
    in >> word;
    EXPECT_EQ(word, "imu") << r.at(0);
    for (int& x : v) in >> x;
    return v;
  }
  // Both ESCs armed (1 s of 1000 us), then `us` on motors 0 and 1, spun up by t = 1.8 s.
  void spinSeesaw(int us) {
    cmd("wr 107 0");
    runTo(1.2);
    cmd(fmt::format("pwm 0 {}", us));
    cmd(fmt::format("pwm 1 {}", us));
    runTo(1.8);
  }
  void TearDown() override {
    con.reset();
    rig.reset();
  }
  std::unique_ptr<sim::AirframeRig> rig;
  std::unique_ptr<sim::Console> con;
};

TEST_F(Airframe, TheImuMeasuresTheRigsRateAndGravity) {
  // given: the gimbal turned by a small torque about x
  make(options(sim::AirRig::kGimbal));
  cmd("wr 107 0");
  rig->plant().setDisturbanceTorque({0.002, 0, 0});
  runTo(0.5);
  // when: the IMU's last sample is held (so the truth can be taken at its time) and the
  // firmware reads it
  const plant::RigTruth t = rig->truth();
  rig->imu()->chip().setFrozen(true);
  const auto v = imu();
  // then: its gyro x is the rig's roll rate (within the DLPF's 1 ms and an LSB) and its
  // accelerometer sees gravity through the tilt
  EXPECT_NEAR(t.t_s, rig->board().timeS() - 0.004, 0.004);  // on the board's clock
  EXPECT_GT(t.rate_dps[0], 2.0);
  EXPECT_NEAR(v[4] / kLsbPerDps, t.rate_dps[0], 0.02);
  EXPECT_NEAR(v[1] / 16384.0, std::sin(t.roll_deg * M_PI / 180), 1.5 / 16384);
  EXPECT_EQ(v[5], 0);
}

TEST_F(Airframe, ImuNackFaultMakesTheFirmwareSeeItsAddressNacked) {
  auto o = options(sim::AirRig::kSeesaw);
  o.faults = {sim::parseAirFault("imu-nack@0.2")};
  make(o);
  EXPECT_NE(cmd("rd 117 1").at(0).find("data 68"), std::string::npos);
  runTo(0.2);
  const auto r = cmd("rd 117 1");
  EXPECT_EQ(r.at(0).rfind("st 08 20 cyc", 0), 0u) << r.at(0);
  ASSERT_EQ(rig->faultsApplied().size(), 1u);
  EXPECT_EQ(rig->faultsApplied()[0], "t=0.2000 s imu-nack@0.2");
}

TEST_F(Airframe, ImuFreezeFaultRepeatsTheSameSampleWhileTheRigMoves) {
  auto o = options(sim::AirRig::kGimbal);
  o.imu_params = sim::Mpu6050Params{};  // a real unit: noise makes every sample differ
  o.imu_params.seed = 5;
  o.faults = {sim::parseAirFault("imu-freeze@0.15")};
  make(o);
  cmd("wr 107 0");
  rig->plant().setDisturbanceTorque({0.01, 0, 0});
  runTo(0.1);
  const auto a = imu();
  runTo(0.11);
  EXPECT_NE(imu(), a);
  runTo(0.16);
  const auto frozen = imu();
  runTo(0.2);
  EXPECT_EQ(imu(), frozen);
  EXPECT_GT(rig->truth().rate_dps[0], 3.0);
}

TEST_F(Airframe, SdaHeldLowMakesTheStartNeverCompleteAndPindReadsSdaLow) {
  auto o = options(sim::AirRig::kSeesaw);
  o.faults = {sim::parseAirFault("sda-low@0.1")};
  make(o);
  EXPECT_EQ(cmd("pins").at(0), "pins 1 1");
  runTo(0.1);
  const auto r = cmd("rd 117 1");
  EXPECT_EQ(r.at(0).rfind("st TO cyc", 0), 0u) << r.at(0);  // TWINT never came
  EXPECT_EQ(cmd("pins").at(0), "pins 0 1");
  runTo(0.3);
  EXPECT_EQ(cmd("recover").at(0), "pins 0 1");  // this slave does not let go
}

TEST_F(Airframe, SdaHeldLowUntilNineClocksIsFreedByBusRecovery) {
  auto o = options(sim::AirRig::kSeesaw);
  o.faults = {sim::parseAirFault("sda-low:9@0.1")};
  make(o);
  runTo(0.1);
  EXPECT_EQ(cmd("rd 117 1").at(0).rfind("st TO", 0), 0u);
  EXPECT_EQ(cmd("recover").at(0), "pins 1 1");
  EXPECT_NE(cmd("rd 117 1").at(0).find("st 08 18 28 10 40 58"), std::string::npos);
}

void holdSdaOnStatus(avr_irq_t*, uint32_t value, void* param) {
  auto* twi = static_cast<sim::Twi*>(param);
  if (value == 0x18 && !twi->sdaHeldLow()) twi->holdSdaLow();
}

TEST_F(Airframe, SdaPulledLowMidTransferLosesArbitrationAt0x38) {
  // given: SDA goes low right after the IMU acknowledged SLA+W
  make(options(sim::AirRig::kSeesaw));
  sim::Twi& twi = rig->board().twi();
  avr_irq_register_notify(twi.irq() + TWI_IRQ_STATUS, holdSdaOnStatus, &twi);
  // when: the register byte 0x3B (a 1 in its third bit) goes out
  const auto r = cmd("rd 59 1");
  avr_irq_unregister_notify(twi.irq() + TWI_IRQ_STATUS, holdSdaOnStatus, &twi);
  // then: the master loses arbitration and stops there
  EXPECT_EQ(r.at(0).rfind("st 08 18 38 cyc", 0), 0u) << r.at(0);
}

TEST_F(Airframe, DeadMotorOnTheSeesawRollsItTowardThatSideInTheFirmwaresGyro) {
  auto o = options(sim::AirRig::kSeesaw);
  o.faults = {sim::parseAirFault("motor-dead:1@1.8")};
  make(o);
  spinSeesaw(1350);
  // right after the fault the two motors were still balanced
  EXPECT_NEAR(rig->truth().roll_deg, 0.0, 0.5);
  EXPECT_GT(rig->plant().actuator(1).thrust_g(), 100.0);
  runTo(2.0);
  const auto v = imu();
  EXPECT_GT(v[4], 20 * kLsbPerDps) << "the right motor (1) died: the left side rises, roll rate > 0";
  EXPECT_GT(rig->truth().roll_deg, 1.0);
}

TEST_F(Airframe, PropellerLosingHalfItsThrustRollsTheSeesawItsWay) {
  auto o = options(sim::AirRig::kSeesaw);
  o.faults = {sim::parseAirFault("prop-loss:0:0.5@1.8")};
  make(o);
  spinSeesaw(1350);
  runTo(1.95);
  const auto v = imu();
  EXPECT_LT(v[4], -5 * kLsbPerDps) << "the left propeller (0) weakened: the left side sinks";
  EXPECT_LT(rig->truth().roll_deg, -1.0);
  EXPECT_GT(rig->plant().actuator(0).rpm(), rig->plant().actuator(1).rpm());
}

TEST_F(Airframe, TheImuKeepsSamplingAcrossABoardReset) {
  make(options(sim::AirRig::kGimbal));
  cmd("wr 107 0");
  runTo(0.05);
  rig->board().reset();
  con->waitPrompt(0.1);
  const uint64_t before = rig->imu()->chip().updates();
  runTo(0.1);
  EXPECT_GT(rig->imu()->chip().updates(), before + 300);  // 8 kHz at DLPF_CFG 0: its own clock
  EXPECT_NE(cmd("rd 117 1").at(0).find("data 68"), std::string::npos);  // and the TWI came back
}

TEST_F(Airframe, TheMinimalExampleReadsWhoAmIAndOneGOnZ) {
  if (std::string(IMU_EXAMPLE_ELF).empty()) GTEST_SKIP();
  make(options(sim::AirRig::kGimbal), IMU_EXAMPLE_ELF);
  con->expectText("WHO_AM_I 0x68", 0.1);
  const auto g = con->expect(R"(^accel (-?\d+) (-?\d+) (-?\d+) raw  mg (-?\d+) (-?\d+) (-?\d+)  read (\d+) cycles$)", 0.2);
  EXPECT_EQ(g[1], "0");
  EXPECT_EQ(g[2], "0");
  EXPECT_EQ(g[3], "16384");
  EXPECT_EQ(g[6], "1000");
  EXPECT_LT(std::stoi(g[7]), 6000);  // six bytes at 400 kHz
}

std::string exampleOutput(uint64_t seed) {
  sim::AirframeOptions o;
  o.rig = sim::AirRig::kSeesaw;
  o.imu_params.seed = seed;
  sim::AirframeRig rig(IMU_EXAMPLE_ELF, o);
  rig.run(0.35);
  return rig.board().output();
}

TEST_F(Airframe, SameSeedSameBytesAnotherSeedAnotherUnit) {
  if (std::string(IMU_EXAMPLE_ELF).empty()) GTEST_SKIP();
  const std::string a = exampleOutput(3);
  EXPECT_NE(a.find("accel"), std::string::npos);
  EXPECT_EQ(exampleOutput(3), a);
  EXPECT_NE(exampleOutput(4), a);
}

TEST_F(Airframe, TheLogHasOneRowPerPeriodWithEveryColumn) {
  auto o = options(sim::AirRig::kGimbal);
  o.log_period_s = 0.01;
  make(o);
  runTo(0.1);
  rig->truth();
  ASSERT_EQ(rig->samples().size(), 11u);  // 0, 0.01, ..., 0.10
  EXPECT_NEAR(rig->samples().back().truth.t_s, 0.1, 1e-9);
  const std::string header = sim::AirframeRig::csvHeader(4);
  const std::string row = sim::AirframeRig::csvRow(rig->samples().back());
  EXPECT_EQ(std::count(header.begin(), header.end(), ','), std::count(row.begin(), row.end(), ','));
  EXPECT_EQ(header.rfind("t_s,roll_deg,pitch_deg,yaw_deg,rate_x_dps", 0), 0u);
  EXPECT_NE(header.find("force3_g"), std::string::npos);
}

struct FaultCase {
  std::string spec;
  sim::AirFault::Kind kind;
  double at_s;
  int motor;
  double share;
  int clocks;
};

TEST(AirFault, ParsesEveryKind) {
  using K = sim::AirFault::Kind;
  const FaultCase cases[] = {{"imu-nack@2.0", K::kImuNack, 2.0, -1, 0, 0},
                             {"imu-freeze@0.5", K::kImuFreeze, 0.5, -1, 0, 0},
                             {"sda-low@1", K::kSdaLow, 1.0, -1, 0, 0},
                             {"sda-low:9@1.5", K::kSdaLow, 1.5, -1, 0, 9},
                             {"motor-dead:1@3.0", K::kMotorDead, 3.0, 1, 0, 0},
                             {"prop-loss:2:0.3@3", K::kPropLoss, 3.0, 2, 0.3, 0}};
  for (const auto& c : cases) {
    const sim::AirFault f = sim::parseAirFault(c.spec);
    EXPECT_EQ(f.kind, c.kind) << c.spec;
    EXPECT_DOUBLE_EQ(f.at_s, c.at_s) << c.spec;
    EXPECT_EQ(f.motor, c.motor) << c.spec;
    EXPECT_DOUBLE_EQ(f.share, c.share) << c.spec;
    EXPECT_EQ(f.release_clocks, c.clocks) << c.spec;
  }
}

TEST(AirFault, SaysWhatIsWrongAndWhatToWrite) {
  const std::pair<const char*, const char*> bad[] = {
      {"imu-nack", "no time: add @T"},
      {"imu-nack@soon", "the time 'soon' is not a number"},
      {"motor-dead@2", "motor-dead takes the form motor-dead:M@T"},
      {"motor-dead:x@2", "the motor M 'x' is not a number"},
      {"prop-loss:1:1.5@2", "the share 1.5 is not within 0..1"},
      {"wing-off@2", "'wing-off' is not a fault kind"},
      {"imu-nack@-1", "the time is negative"}};
  for (const auto& [spec, message] : bad) {
    try {
      sim::parseAirFault(spec);
      ADD_FAILURE() << spec << " was accepted";
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(message), std::string::npos) << what;
      EXPECT_NE(what.find("prop-loss:M:S@T"), std::string::npos) << "the syntax is shown: " << what;
    }
  }
}

TEST_F(Airframe, AFaultOnAMotorTheRigLacksIsRefusedAtOnce) {
  auto o = options(sim::AirRig::kSeesaw);
  o.faults = {sim::parseAirFault("motor-dead:3@1")};
  EXPECT_THROW(make(o), std::invalid_argument);
}

TEST_F(Airframe, ABoardWithoutARigGetsTheStillImuAndItsFaultsAtTheirCycle) {
  // given: `sim run/console --rig none|bench|quad --imu mpu6050 --fault ...`
  sim::Board board(AIR_PROBE_ELF);
  sim::AirCliOptions o;
  o.imu = "mpu6050";
  o.imu_ideal = true;
  o.faults = {"imu-nack@0.1", "sda-low@0.2"};
  sim::StillAirframe still(board, "none", o);
  sim::Console c(board, "a> ");
  c.waitPrompt(0.1);
  c.command("wr 107 0");
  board.runFor(0.05);
  EXPECT_EQ(c.command("imu").at(0), "imu 0 0 16384 -3920 0 0 0");  // level, 25 C
  board.runFor(0.1);
  EXPECT_EQ(c.command("rd 117 1").at(0).rfind("st 08 20", 0), 0u);
  board.runFor(0.1);
  EXPECT_EQ(c.command("pins").at(0), "pins 0 1");
  ASSERT_EQ(still.faultsApplied().size(), 2u);
  EXPECT_EQ(still.faultsApplied()[1], "t=0.2000 s sda-low@0.2");
  // and a rig-only option is refused with what to do
  o.log = "x.csv";
  try {
    sim::StillAirframe refused(board, "quad", o);
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("use --rig seesaw or gimbal"), std::string::npos) << e.what();
  }
}

using air::shell;

TEST_F(Airframe, SimRunPrintsTheUartAndWritesTheTruthLog) {
  if (std::string(IMU_EXAMPLE_ELF).empty()) GTEST_SKIP();
  const std::string log = std::string(AIR_TEST_TMP) + "/sim_run_log.csv";
  std::remove(log.c_str());
  int status = 0;
  const std::string out = shell(fmt::format("{} sim run --elf {} --imu mpu6050 --imu-ideal --rig seesaw "
                                            "--duration 0.25 --log {} --fault imu-nack@0.2",
                                            THRUSTCAL_BIN, IMU_EXAMPLE_ELF, log),
                                status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("WHO_AM_I 0x68"), std::string::npos) << out;
  EXPECT_NE(out.find("accel 0 0 16384 raw"), std::string::npos) << out;
  EXPECT_NE(out.find("fault applied: t=0.2000 s imu-nack@0.2"), std::string::npos) << out;
  std::ifstream in(log);
  std::string line, header;
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header.empty()) header = line;
    else ++rows;
  }
  EXPECT_EQ(header.rfind("t_s,roll_deg", 0), 0u);
  EXPECT_GE(rows, 25);  // 0.00 .. 0.24 s, and 0.25 s if the last tick came before the end
  EXPECT_LE(rows, 26);
  const std::string bad = shell(fmt::format("{} sim run --elf {} --duration 1 --fault motor-dead:0@1",
                                            THRUSTCAL_BIN, IMU_EXAMPLE_ELF),
                                status);
  EXPECT_NE(status, 0);
  EXPECT_NE(bad.find("motor faults need --rig seesaw or gimbal"), std::string::npos) << bad;
}

}  // namespace

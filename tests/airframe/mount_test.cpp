// The IMU's mounting (`--imu-mount`) and the propellers' directions (`--spin`) on the command
// line (issue 25, items 2 and 3): in each of the eight mounts, air_probe on the tilted, turning
// gimbal reads the rig's specific force and rates in the chip's own axes, with the signs a table
// written out by hand says (chip axis = +-body axis), and a chip lying upside down on a still
// board reads -1 g.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <ostream>
#include <sstream>
#include <string>

#include "air_support.hpp"
#include "sim/air_cli.hpp"
#include "sim/airframe.hpp"

namespace {

constexpr double kMountLsbPerG = 16384.0;   // air_probe leaves AFS_SEL 0
constexpr double kMountLsbPerDps = 131.0;   // and FS_SEL 0

// Chip axis i measures sign[i] * body axis axis[i] (0 x forward, 1 y left, 2 z up).
struct MountCase {
  const char* spec;
  std::array<int, 3> axis;
  std::array<int, 3> sign;
};
// Worked out on paper from the drawing in docs/sim.md ("The IMU's mounting").
constexpr MountCase kMounts[] = {
    {"yaw0", {0, 1, 2}, {1, 1, 1}},          {"yaw90", {1, 0, 2}, {1, -1, 1}},
    {"yaw180", {0, 1, 2}, {-1, -1, 1}},      {"yaw270", {1, 0, 2}, {-1, 1, 1}},
    {"flip", {0, 1, 2}, {1, -1, -1}},        {"flip,yaw90", {1, 0, 2}, {1, 1, -1}},
    {"flip,yaw180", {0, 1, 2}, {-1, 1, -1}}, {"flip,yaw270", {1, 0, 2}, {-1, -1, -1}},
};

void PrintTo(const MountCase& m, std::ostream* os) { *os << m.spec; }

// Z-Y-X Euler angles (deg) to a unit quaternion (w, x, y, z), body to world.
std::array<double, 4> quaternionDeg(double roll, double pitch, double yaw) {
  const double k = std::numbers::pi / 360.0;
  const double cr = std::cos(roll * k), sr = std::sin(roll * k), cp = std::cos(pitch * k), sp = std::sin(pitch * k),
               cy = std::cos(yaw * k), sy = std::sin(yaw * k);
  return {cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
          cr * cp * sy - sr * sp * cy};
}

class MountProbe : public ::testing::TestWithParam<MountCase> {
 protected:
  void SetUp() override {
    if (std::string(AIR_PROBE_ELF).empty()) GTEST_SKIP() << "avr-gcc not found: no air_probe image";
  }
};

TEST_P(MountProbe, TheTiltedTurningRigReadsInTheChipsAxesWithTheSignsOfTheMount) {
  const MountCase& m = GetParam();
  sim::AirframeOptions o;
  o.imu_params = air::idealImu();
  o.imu_mount = sim::parseImuMount(m.spec);
  o.gimbal.damping_nms_per_rad = {0, 0, 0};
  sim::AirframeRig rig(AIR_PROBE_ELF, o);
  sim::Console con(rig.board(), "a> ");
  con.waitPrompt(0.1);
  con.command("wr 107 0");
  // given: rolled right side down 20 deg, nose up 10 deg, turned 30 deg, turning about all axes
  rig.gimbal()->setState(quaternionDeg(20, -10, 30), {0.20, -0.10, 0.15});
  rig.run(0.02);
  // when: the firmware reads the chip
  const auto lines = con.command("imu", 0.5);
  const plant::RigTruth t = rig.truth();
  ASSERT_EQ(lines.size(), 1u);
  std::istringstream in(lines[0]);
  std::string word;
  std::array<int, 7> raw{};
  in >> word;
  for (int& x : raw) in >> x;
  // then: each chip axis reads its body axis with the mount's sign
  for (int i = 0; i < 3; ++i) {
    const double want_g = m.sign[i] * t.specific_force_g[m.axis[i]];
    const double want_dps = m.sign[i] * t.rate_dps[m.axis[i]];
    EXPECT_NEAR(raw[i] / kMountLsbPerG, want_g, 0.01) << m.spec << " accel axis " << i;
    EXPECT_NEAR(raw[4 + i] / kMountLsbPerDps, want_dps, 0.3) << m.spec << " gyro axis " << i;
  }
  // and the tilt is large enough on every axis that a wrong sign could not pass
  EXPECT_GT(std::abs(t.specific_force_g[0]), 0.1);
  EXPECT_GT(std::abs(t.specific_force_g[1]), 0.1);
  EXPECT_GT(std::abs(t.rate_dps[2]), 5.0);
}

INSTANTIATE_TEST_SUITE_P(EveryMount, MountProbe, ::testing::ValuesIn(kMounts),
                         [](const auto& info) {
                           std::string name = info.param.spec;
                           for (char& c : name)
                             if (c == ',') c = '_';
                           return name;
                         });

TEST(ImuMount, ParsesEveryMountInEitherOrderAndSaysWhatToWrite) {
  EXPECT_EQ(sim::parseImuMount("yaw270").yaw_deg, 270);
  EXPECT_FALSE(sim::parseImuMount("yaw270").flipped);
  const sim::ImuMount a = sim::parseImuMount("yaw180,flip"), b = sim::parseImuMount("flip,yaw180");
  EXPECT_TRUE(a.flipped && b.flipped);
  EXPECT_EQ(a.yaw_deg, 180);
  EXPECT_EQ(sim::imuMountName(a), "flip,yaw180");
  EXPECT_EQ(sim::imuMountName(sim::parseImuMount("flip")), "flip,yaw0");
  for (const char* bad : {"yaw45", "roll90", "flip,flip", "yaw90,yaw180", ""}) {
    try {
      sim::parseImuMount(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("write yaw0, yaw90, yaw180 or yaw270"), std::string::npos) << e.what();
    }
  }
}

TEST(ImuMount, AChipUpsideDownOnAStillBoardReadsMinusOneG) {
  if (std::string(AIR_PROBE_ELF).empty()) GTEST_SKIP();
  sim::Board board(AIR_PROBE_ELF);
  sim::AirCliOptions o;
  o.imu = "mpu6050";
  o.imu_ideal = true;
  o.imu_mount = "flip,yaw90";
  sim::StillAirframe still(board, "quad", o);
  sim::Console con(board, "a> ");
  con.waitPrompt(0.1);
  con.command("wr 107 0");
  board.runFor(0.01);
  const auto lines = con.command("imu", 0.5);
  ASSERT_EQ(lines.size(), 1u);
  std::istringstream in(lines[0]);
  std::string word;
  int ax = 0, ay = 0, az = 0;
  in >> word >> ax >> ay >> az;
  EXPECT_EQ(ax, 0);
  EXPECT_EQ(ay, 0);
  EXPECT_EQ(az, -16384);
}

TEST(Spin, ParsesOneDirectionPerMotorAndRefusesTheRest) {
  EXPECT_EQ(sim::parseSpin("cw,ccw,cw,ccw", 4), (std::vector<int>{-1, 1, -1, 1}));
  const struct {
    const char* text;
    const char* says;
  } bad[] = {{"cw,ccw,cw", "3 directions for a rig with 4 motors"}, {"cw,ccw,left,ccw", "'left' is neither cw nor ccw"},
             {"", "'' is neither cw nor ccw"}};
  for (const auto& b : bad) {
    try {
      sim::parseSpin(b.text, 4);
      ADD_FAILURE() << b.text << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(b.says), std::string::npos) << e.what();
    }
  }
}

TEST(Spin, TheGimbalTakesItAndTheSeesawAndStillBoardsRefuseIt) {
  if (std::string(AIR_PROBE_ELF).empty()) GTEST_SKIP();
  sim::AirCliOptions o;
  o.spin = "cw,ccw,cw,ccw";
  const auto rig = sim::makeAirframeRig(AIR_PROBE_ELF, "gimbal", "kv1100_9x4.7", {1, 2, 3, 4}, o);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(rig->plant().mount(i).spin, i % 2 == 0 ? -1 : 1) << i;
  EXPECT_NE(rig->describe().find("kv1100_9x4.7#1 CW, kv1100_9x4.7#2 CCW"), std::string::npos) << rig->describe();
  try {
    sim::makeAirframeRig(AIR_PROBE_ELF, "seesaw", "kv1100_9x4.7", {1, 2}, o);
    ADD_FAILURE() << "the seesaw took --spin";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("use --spin with --rig gimbal"), std::string::npos) << e.what();
  }
  sim::Board board(AIR_PROBE_ELF);
  EXPECT_THROW(sim::StillAirframe(board, "quad", o), std::invalid_argument);
}

}  // namespace

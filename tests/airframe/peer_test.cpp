// A peer on the gimbal (issue 25, item 6): peer_quad (tests/airframe/peer_quad), a small
// MultiWii-like firmware (phase-correct PWM on D3, D5, D6, D2; a PCINT receiver on A8..A11; an
// angle-mode PID on PWM), flies the gimbal in the X layout with the rig's motors on its pins and
// its propellers' directions, its sticks from an RC script: nothing spins before the arming
// sequence, a roll stick of +10 degrees tilts the rig to +10 degrees, and losing the signal
// stops the motors. Then the same firmware as a peer in the swap, from its profile file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "sim/air_cli.hpp"
#include "sim/airframe.hpp"
#include "sim/peer_profile.hpp"
#include "sim/rc_input.hpp"
#include "sim/swap.hpp"
#include "sim/swap_report.hpp"

namespace {

constexpr const char* kPeerSticks =
    "t_s,ch1,ch2,ch3,ch4\n"  // throttle, roll, pitch, yaw (A8..A11)
    "0.0,1000,1500,1500,1500\n"
    "0.3,1000,1500,1500,2000\n"  // arm: throttle low, yaw right for 1 s
    "1.5,1450,1500,1500,1500\n"  // hover
    "3.0,1450,1600,1500,1500\n"  // roll +10 degrees (10 us per degree)
    "4.5,loss\n";

double meanOf(const std::vector<sim::AirSample>& rows, double from_s, double to_s,
              double plant::RigTruth::*field) {
  double sum = 0;
  int n = 0;
  for (const sim::AirSample& s : rows)
    if (s.truth.t_s >= from_s && s.truth.t_s < to_s) sum += s.truth.*field, ++n;
  return n ? sum / n : NAN;
}

double maxPulse(const std::vector<sim::AirSample>& rows, double from_s, double to_s) {
  double top = 0;
  for (const sim::AirSample& s : rows)
    if (s.truth.t_s >= from_s && s.truth.t_s < to_s)
      for (int i = 0; i < s.motors; ++i) top = std::max(top, s.pulse_us[i]);
  return top;
}

TEST(PeerOnGimbal, ArmsOnTheSticksFollowsARollStepAndStopsOnLoss) {
  if (std::string(PEER_QUAD_ELF).empty()) GTEST_SKIP() << "avr-gcc not found: no peer_quad image";
  sim::AirframeOptions o;
  o.rig = sim::AirRig::kGimbal;
  o.gimbal.layout = plant::Layout::kX;
  o.gimbal.common.spin = sim::parseSpin("cw,ccw,cw,ccw", 4);  // front-left and rear-right clockwise
  o.esc_pins = sim::parseEscPins("D2,D6,D3,D5");               // rig motor 0..3 = its FL, RL, RR, FR
  o.imu_params.seed = 1;
  o.log_period_s = 0.01;
  sim::AirframeRig rig(PEER_QUAD_ELF, o);
  sim::RcOnBoard rc(rig.board(), sim::parseRcSpec("pwm:A8,A9,A10,A11", &o.esc_pins));
  rc.play(sim::parseRcScript(kPeerSticks, "sticks"));
  rig.run(5.0);
  const std::string& out = rig.board().output();
  const auto& rows = rig.samples();
  const auto mean = [&](double a, double b, double plant::RigTruth::*f) {
    return meanOf(rows, a, b, f);
  };
  ASSERT_NE(out.find("peer_quad"), std::string::npos) << out;
  ASSERT_NE(out.find("armed"), std::string::npos) << out;
  EXPECT_LT(maxPulse(rows, 0.2, 1.2), 1001.0) << "a motor ran before the arming sequence ended";
  EXPECT_NEAR(mean(2.5, 3.0, &plant::RigTruth::roll_deg), 0.0, 1.5);
  EXPECT_NEAR(mean(2.5, 3.0, &plant::RigTruth::pitch_deg), 0.0, 1.5);
  EXPECT_NEAR(mean(4.0, 4.5, &plant::RigTruth::roll_deg), 10.0, 1.5);
  EXPECT_NEAR(mean(4.0, 4.5, &plant::RigTruth::pitch_deg), 0.0, 1.5);
  EXPECT_LT(std::fabs(rig.truth().rate_dps[2]), 20.0) << "the yaw loop pushes the wrong way";
  EXPECT_NE(out.find("failsafe"), std::string::npos) << out;
  EXPECT_LT(maxPulse(rows, 4.9, 5.0), 1001.0) << "the motors ran on after the signal was lost";
}

}  // namespace

namespace {

std::string peerProfileText(const std::string& elf) {
  return "# peer_quad: the tests' MultiWii-like peer (tests/airframe/peer_quad)\n"
         "name peer_quad\n"
         "elf " + elf + "\n"
         "layout x\n"
         "esc-pins D2,D6,D3,D5   # rig motors 0..3 = its front-left, rear-left, rear-right, front-right\n"
         "spin cw,ccw,cw,ccw\n"
         "imu-mount yaw0\n"
         "rc pwm:A8,A9,A10,A11\n"
         "channels throttle,roll,pitch,yaw\n"
         "neutral throttle=1000\n"
         "boot-s 0.3\n"
         "arm throttle=1000,yaw=2000 hold 1.2\n"
         "armed-text armed\n"
         "hover throttle=1450\n"
         "deg-us roll 10\n"
         "deg-us pitch 10\n";
}

TEST(PeerProfile, ReadsAProfileAndNamesTheLineOfAMistake) {
  const sim::PeerProfile p = sim::parsePeerProfile(peerProfileText("/x/peer.elf"), "/p/peer.txt");
  EXPECT_EQ(p.name, "peer_quad");
  EXPECT_EQ(p.esc_pins[0].arduino, 2);
  EXPECT_EQ(p.spin, (std::vector<int>{-1, 1, -1, 1}));
  EXPECT_EQ(p.channelValues(p.arm), (std::vector<double>{1000, 1500, 1500, 2000}));
  EXPECT_EQ(p.channelValues(p.hover), (std::vector<double>{1450, 1500, 1500, 1500}));
  EXPECT_TRUE(p.calibrate.empty());
  const sim::PeerProfile c = sim::parsePeerProfile(
      peerProfileText("e") + "calibrate throttle=2000,yaw=1000,pitch=1000 hold 1 wait 1.5\n", "peer.txt");
  EXPECT_EQ(c.channelValues(c.calibrate), (std::vector<double>{2000, 1500, 1000, 1000}));
  EXPECT_DOUBLE_EQ(c.calibrate_hold_s, 1.0);
  EXPECT_DOUBLE_EQ(c.calibrate_wait_s, 1.5);
  EXPECT_EQ(sim::parsePeerProfile(peerProfileText("e") + "uart-hex 24 4d 3C 00 FA fa\n", "peer.txt").uart_bytes,
            std::string("$M<\x00\xFA\xFA", 6));
  EXPECT_EQ(sim::parsePeerProfile("elf peer.elf\n" + peerProfileText("x").substr(0, 0) +
                                      peerProfileText("x").substr(peerProfileText("x").find("layout")) +
                                      "name n\n",
                                  "/p/q.txt")
                .elf,
            "/p/peer.elf");  // relative to the profile's folder
  const struct {
    std::string edit, says;
  } bad[] = {
      {"deg-us roll 12\n", "peer.txt:17: 'deg-us roll' is given twice"},
      {"arm throttle=1000,yaw=2000\n", "peer.txt:17: 'arm' is given twice"},
      {"boot 1\n", "peer.txt:17: unknown key 'boot'"},
      {"calibrate throttle=2000 hold 1\n", "peer.txt:17: write the calibration sticks"},
      {"uart-hex 24 4D 3C0\n", "peer.txt:17: '3C0' is not a byte in hex"},
      {"rc pwm:A8,A9\n", "'rc' is given twice"},
  };
  for (const auto& b : bad) {
    try {
      sim::parsePeerProfile(peerProfileText("e") + b.edit, "peer.txt");
      ADD_FAILURE() << b.edit << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(b.says), std::string::npos) << b.edit << ": " << e.what();
    }
  }
  std::string no_arm = peerProfileText("e");
  no_arm.erase(no_arm.find("arm throttle"), no_arm.find("armed-text") - no_arm.find("arm throttle"));
  EXPECT_THROW(sim::parsePeerProfile(no_arm, "peer.txt"), std::invalid_argument);
  std::string rudder = peerProfileText("e");
  rudder.replace(rudder.find("hover throttle=1450"), 19, "hover throttle=1450,rudder=1500");
  try {
    sim::parsePeerProfile(rudder, "peer.txt");
    ADD_FAILURE() << "a stick named rudder was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("peer.txt:14: 'rudder=1500' is not STICK=US"), std::string::npos) << e.what();
  }
  std::string esc_rc = peerProfileText("e");
  esc_rc.replace(esc_rc.find("pwm:A8"), 6, "pwm:D2");
  try {
    sim::parsePeerProfile(esc_rc, "peer.txt");
    ADD_FAILURE() << "a receiver pin on an ESC pin was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("both a receiver pin and an ESC pin"), std::string::npos) << e.what();
  }
}

// The swap with the peer alone (nothing calibrated): stock and a propeller 8 % weaker in slot 1,
// roll and pitch, one IMU unit: four flights whose runs carry mode peer:peer_quad.
TEST(PeerInSwap, TheProfileFliesTheGimbalWithEachPartAndItsRunsJoinRuns) {
  if (std::string(PEER_QUAD_ELF).empty()) GTEST_SKIP() << "avr-gcc not found: no peer_quad image";
  const std::string dir = std::string(AIR_TEST_TMP) + "/peer_swap";
  std::filesystem::create_directories(dir);
  {
    std::ofstream(dir + "/peer_quad.txt") << peerProfileText(PEER_QUAD_ELF);
  }
  sim::swap::SwapOptions o;
  o.peer = std::make_shared<const sim::PeerProfile>(sim::readPeerProfile(dir + "/peer_quad.txt"));
  o.modes.clear();
  o.rigs = {sim::AirRig::kGimbal};
  o.parts = {"prop-8pct"};
  o.imu_seeds = {1};
  o.settle_s = 0.5;
  o.window_s = 2.0;
  o.out_dir = dir;
  o.jobs = 2;
  o.progress = [](const std::string&) {};
  const sim::swap::SwapResult r = sim::swap::runSwap(o);
  ASSERT_EQ(r.runs.size(), 4u);
  const nlohmann::json j = r.toJson();
  for (const auto& run : j["runs"]) {
    EXPECT_EQ(run["mode"], "peer:peer_quad");
    EXPECT_EQ(run["gains"], "own");
    EXPECT_EQ(run["rig"], "gimbal");
    // Within the IMU unit's zero-g offset: the peer levels on its accelerometer, uncalibrated.
    EXPECT_NEAR(run["final_deg"].get<double>(), 10.0, 2.5) << run.dump();
    EXPECT_NEAR(run["y0_deg"].get<double>(), 0.0, 2.5) << run.dump();
    EXPECT_LT(run["peak_deg"].get<double>(), 18.0) << run.dump();  // its own gains overshoot, but it holds
    ASSERT_TRUE(run["rise_s"].is_number()) << run.dump();
    EXPECT_GT(run["rise_s"].get<double>(), 0.02);
    EXPECT_LT(run["rise_s"].get<double>(), 0.8);
    EXPECT_TRUE(std::filesystem::exists(run["csv"].get<std::string>()));
  }
  EXPECT_EQ(j["setup"]["peer"]["name"], "peer_quad");
  EXPECT_TRUE(r.targets.empty());  // the targets are fly's force mode's
  const std::string table = sim::swap::formatTable(r);
  EXPECT_NE(table.find("peer:peer_quad prop-8pct"), std::string::npos) << table;
}

}  // namespace

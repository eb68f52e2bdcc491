// A peer on the gimbal (issue 25, item 6): peer_quad (tests/airframe/peer_quad), a small
// MultiWii-like firmware (phase-correct PWM on D3, D5, D6, D2; a PCINT receiver on A8..A11; an
// angle-mode PID on PWM), flies the gimbal in the X layout with the rig's motors on its pins and
// its propellers' directions, its sticks from an RC script: nothing spins before the arming
// sequence, a roll stick of +10 degrees tilts the rig to +10 degrees, and losing the signal
// stops the motors.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "sim/air_cli.hpp"
#include "sim/airframe.hpp"
#include "sim/rc_input.hpp"

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

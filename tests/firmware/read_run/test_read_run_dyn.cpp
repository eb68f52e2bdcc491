// read_run's `dyn on|off` against the fake HAL (equal dynamics, thrustcal/dyn_shaper.hpp): v2
// records with different measured time constants are shaped onto one response, a record
// without dynamics flies its force as commanded, a stop is immediate, and the console refuses
// what it must.
//
// Seam: as test_read_run_v2.cpp; each motor's force is integrated here from the force the
// frame flew (Motor::shaped_dg) through its own first-order lag, frame by frame.
#include <gtest/gtest.h>

#include <math.h>

#include <string>
#include <vector>

#include "read_run_fixture.hpp"

namespace {

using namespace rr_test;
namespace fake = hal::fake;


tc::MotorDynamics lawMs(uint16_t up_ms, uint16_t down_ms) {
  tc::MotorDynamics d;
  d.points = 5;
  d.lo_dg = 1000;
  d.hi_dg = 4000;
  d.up_lo_01ms = d.up_hi_01ms = static_cast<uint16_t>(up_ms * 10);
  d.down_lo_01ms = d.down_hi_01ms = static_cast<uint16_t>(down_ms * 10);
  return d;
}

// Motors 0-2 measured (70, 85 and 100 ms up; spin-down 10 % slower), motor 3 never was.
const tc::MotorDynamics kLaws[3] = {lawMs(70, 77), lawMs(85, 94), lawMs(100, 110)};

class ReadRunDyn : public ReadRun {
 protected:
  void storeMotors(bool with_dynamics) {
    for (uint8_t m = 0; m < rr::kMotors; ++m) {
      tc::ModelV2 model = fitV2Model(kPlantK[m], mvFromCounts(kCountsV1));
      if (with_dynamics && m < 3) model.dynamics = kLaws[m];
      ASSERT_EQ(tc::writeModelV2<hal::Eeprom>(m, model).status, tc::WriteV2Status::kWritten);
    }
  }

  void runFrames(uint32_t frames) {
    const uint32_t target = fake::adcConversions() + frames * fw::BatteryInput::kSamplesPerFrame;
    while (fake::adcConversions() < target) {
      hal::Clock::sleepUntilInterrupt();
      app_->runOnce();
    }
  }

  // `frames` frames after a command, each motor's force (g) through its own lag (motor 3: 60 ms)
  // from `from_g`, settled; the forces per frame, motor by motor.
  std::vector<std::vector<double>> flyStep(double from_g, uint32_t frames, uint16_t frame_hz) {
    std::vector<std::vector<double>> force(rr::kMotors);
    std::vector<double> y(rr::kMotors, from_g);
    for (uint32_t k = 0; k < frames; ++k) {
      if (k % (frame_hz / 5) == frame_hz / 10) fake::feedInput("\n");  // the keep-alive, 5 a second
      runFrames(1);
      for (uint8_t m = 0; m < rr::kMotors; ++m) {
        const double u = app_->motor(m).shaped_dg * 0.1;
        const double tau = m < 3 ? (u >= y[m] ? kLaws[m].tauUpS(0) : kLaws[m].tauDownS(0)) : 0.060;
        y[m] = u + (y[m] - u) * exp(-1.0 / (frame_hz * tau));
        force[m].push_back(y[m]);
      }
    }
    return force;
  }
};

double spreadG(const std::vector<std::vector<double>>& force, uint8_t motors) {
  double worst = 0.0;
  for (size_t k = 0; k < force[0].size(); ++k) {
    double lo = 1e9, hi = -1e9;
    for (uint8_t m = 0; m < motors; ++m) {
      lo = std::min(lo, force[m][k]);
      hi = std::max(hi, force[m][k]);
    }
    worst = std::max(worst, hi - lo);
  }
  return worst;
}

TEST_F(ReadRunDyn, ShapedMotorsFollowTheSlowestOnesResponseAndTheUnmeasuredOneIsUnchanged) {
  // given
  storeMotors(true);
  boot();
  EXPECT_NE(command("status").find("dyn off: every motor flies its force as commanded"), std::string::npos);
  command("rate 200");
  // when
  const std::string reply = command("dyn on");
  // then
  EXPECT_NE(reply.find("dyn on: motors 0 1 2 follow the slowest motor's response; motor 3 flies "
                       "unshaped (no dynamics)"),
            std::string::npos)
      << reply;
  EXPECT_NE(command("status").find("dyn on: motors 0 1 2"), std::string::npos);

  // when: 300 g settled, then a step to 400 g, 0.6 s of frames
  command("f 300");
  runFor(2000, true);
  fake::feedInput("f 400\n");
  const auto step = flyStep(300.0, 120, 200);
  // then: the three measured motors' forces stay within 0.5 g of each other (unshaped, 70 and
  // 100 ms lags are up to 8 g apart on this step); motor 3 flew the command as given
  EXPECT_LT(spreadG(step, 3), 0.5);
  EXPECT_NEAR(step[2][119], 400.0, 1.0);
  EXPECT_EQ(app_->motor(3).shaped_dg, 4000);
  EXPECT_LT(app_->motor(0).shaped_dg, 4000) << "the fastest motor is still held back at 0.6 s";

  // when: stop; then every pulse stops at once
  command("stop");
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(pulse(m), tc::kStopPwmUs);

  // when: the same step with dyn off; then the three lags spread the forces apart
  command("dyn off");
  command("f 300");
  runFor(2000, true);
  fake::feedInput("f 400\n");
  EXPECT_GT(spreadG(flyStep(300.0, 120, 200), 3), 5.0);
}

TEST_F(ReadRunDyn, AFixedReferenceAndOffAndTheRefusals) {
  storeMotors(true);
  boot();
  EXPECT_NE(command("dyn on 120 130").find("dyn on: motors 0 1 2 follow a fixed response, up 120.0 ms, down 130.0 ms"),
            std::string::npos);
  EXPECT_NE(command("dyn on 120").find("error: dyn on takes both UP_MS and DOWN_MS, or neither"), std::string::npos);
  EXPECT_NE(command("dyn off 120 130").find("error: dyn off takes no time constants"), std::string::npos);
  EXPECT_NE(command("dyn on 2 130").find("error: UP_MS must be a whole number"), std::string::npos);
  command("f 300");
  EXPECT_NE(command("dyn off").find("error: motors are running; send stop first, then dyn"), std::string::npos);
  runFor(200, true);
  EXPECT_LT(app_->motor(2).shaped_dg, 3000) << "shaping still on: the command ramps";
  command("stop");
  EXPECT_NE(command("dyn off").find("dyn off: every motor flies its force as commanded"), std::string::npos);
  command("f 300");
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(app_->motor(m).shaped_dg, 3000);
}

TEST_F(ReadRunDyn, WithoutAnyDynamicsDynOnIsRefusedAndNothingChanges) {
  storeMotors(false);
  boot();
  EXPECT_NE(command("dyn on").find("error: dyn: no calibrated motor has dynamics; measure them with "
                                   "gather_store's dyn, then store v2"),
            std::string::npos);
  EXPECT_FALSE(app_->motors().isShaping());
  command("f 300");
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(app_->motor(m).shaped_dg, 3000);
}

}  // namespace

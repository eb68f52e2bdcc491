// fly's pure rules (firmware/fly/fly_rules.hpp), checked without booting the image: arming
// refusals in the order a user fixes them, the crash limit, the frame's layout, the frame counts
// and the spool-up.
#include <gtest/gtest.h>

#include "fly_rules.hpp"

namespace {

using namespace fly;

ArmInputs readyToArm() {
  ArmInputs in;
  in.escs_ready = true;
  in.imu_ready = true;
  in.motors_ok = true;
  in.mode_ready = true;
  return in;
}

TEST(FlyRules, ArmingIsRefusedForEachReasonInTheOrderAUserFixesThem) {
  EXPECT_EQ(armRefusal(readyToArm()), ArmRefusal::kNone);
  struct Case {
    void (*change)(ArmInputs&);
    ArmRefusal why;
  };
  const Case cases[] = {
      {[](ArmInputs& in) { in.armed = true; }, ArmRefusal::kArmed},
      {[](ArmInputs& in) { in.imu_fault = true; }, ArmRefusal::kImuFault},
      {[](ArmInputs& in) { in.imu_ready = false; }, ArmRefusal::kImuStarting},
      {[](ArmInputs& in) { in.escs_ready = false; }, ArmRefusal::kEscsArming},
      {[](ArmInputs& in) { in.roll_deg = 5.5f; }, ArmRefusal::kNotLevel},
      {[](ArmInputs& in) { in.pitch_deg = -6.0f; }, ArmRefusal::kNotLevel},
      {[](ArmInputs& in) { in.rate_dps[2] = 5.1f; }, ArmRefusal::kMoving},
      {[](ArmInputs& in) { in.rate_dps[0] = -8.0f; }, ArmRefusal::kMoving},
      {[](ArmInputs& in) { in.motors_ok = false; }, ArmRefusal::kMotorNotCalibrated},
      {[](ArmInputs& in) { in.mode_ready = false; }, ArmRefusal::kModeNeedsSettings},
      // two at once: the first in the order wins
      {[](ArmInputs& in) {
         in.imu_fault = true;
         in.roll_deg = 30;
       },
       ArmRefusal::kImuFault},
      {[](ArmInputs& in) {
         in.roll_deg = 30;
         in.rate_dps[1] = 50;
       },
       ArmRefusal::kNotLevel},
  };
  for (const Case& c : cases) {
    ArmInputs in = readyToArm();
    c.change(in);
    EXPECT_EQ(armRefusal(in), c.why) << static_cast<int>(c.why);
  }
  ArmInputs edge = readyToArm();
  edge.roll_deg = kArmLevelDeg;
  edge.rate_dps[0] = -kArmStillDps;
  EXPECT_EQ(armRefusal(edge), ArmRefusal::kNone) << "the limits themselves are allowed";
}

TEST(FlyRules, ACrashIsRollOrPitchBeyondTheLimitEitherWay) {
  const float limit = 45 * 3.14159265f / 180;
  EXPECT_FALSE(crashed(0.78f, -0.78f, limit));
  EXPECT_TRUE(crashed(0.79f, 0, limit));
  EXPECT_TRUE(crashed(0, -0.79f, limit));
  EXPECT_TRUE(crashed(-3.0f, 0, limit)) << "upside down";
}

TEST(FlyRules, TheReceiverFailsafeActsEarlyEnoughForTheStopPulseWithin100Ms) {
  // the latency to the pins at 400 Hz: two 2.5 ms frames, the 1 ms clock, a 2 ms pulse
  EXPECT_EQ(kRcStopMs, 100);
  EXPECT_EQ(kRcStopLatencyMs, 8);
  EXPECT_EQ(kRcLossMs, 92);
  EXPECT_FALSE(receiverLost(1091, 1000));
  EXPECT_TRUE(receiverLost(1092, 1000));
  EXPECT_FALSE(receiverLost(50, 0xFFFFFFF0u)) << "66 ms across the clock's wrap";
  EXPECT_TRUE(receiverLost(100, 0xFFFFFFF0u));
}

TEST(FlyRules, TheReadStartsAsLateAsTheBudgetAllowsSoTheResultMeetsTheNextEdge) {
  EXPECT_EQ(kFrameUs, 2500);
  EXPECT_EQ(readPhaseUs(500), 2500 - kImuReadUs - 500);
  EXPECT_EQ(readPhaseUs(3000), kMinPhaseUs) << "a budget beyond the frame: as early as allowed";
  // model v2 on four motors: read, compute and write well under a millisecond before the edge
  const uint16_t v2 = computeBudgetUs(OutputMode::kForce, 0, 4);
  EXPECT_LT(v2, 1000);
  EXPECT_EQ(readPhaseUs(v2) + kImuReadUs + v2, kFrameUs);
  // the thesis records get no time of their own (the 1 ms target leaves none); pwm least
  EXPECT_EQ(computeBudgetUs(OutputMode::kForce, 4, 4), computeBudgetUs(OutputMode::kForce, 1, 4));
  EXPECT_LT(computeBudgetUs(OutputMode::kPwm, 0, 4), v2);
  EXPECT_EQ(computeBudgetUs(OutputMode::kArduPilot, 0, 2) + 2 * kArduPilotMotorBudgetUs,
            computeBudgetUs(OutputMode::kArduPilot, 0, 4));
  EXPECT_GE(readPhaseUs(computeBudgetUs(OutputMode::kForce, 4, 4)), kMinPhaseUs);
  // thesis records on four motors leave a console window before the read as every mode does:
  // a line is kept out of it (consoleMayStart), not taken whenever it comes
  const uint16_t thesis_phase_us = readPhaseUs(computeBudgetUs(OutputMode::kForce, 4, 4));
  EXPECT_GE(thesis_phase_us, kMinPhaseUs + kConsoleSliceUs);
  EXPECT_FALSE(consoleMayStart(static_cast<uint16_t>(thesis_phase_us - kConsoleSliceUs), thesis_phase_us));
  EXPECT_TRUE(consoleMayStart(0, thesis_phase_us));
}

// Issue 19 item 4: read end to edge at most 1 ms needs a budget at most ~780 us (the read's
// ~220 us of kImuReadUs spare come on top), thesis records on four motors too (fly_rules.hpp).
TEST(FlyRules, TheBudgetsOfEveryModeKeepReadToEdgeWithinAMillisecond) {
  for (OutputMode mode : {OutputMode::kForce, OutputMode::kGeneric, OutputMode::kPwm, OutputMode::kArduPilot}) {
    EXPECT_LE(computeBudgetUs(mode, 0, 4), 780) << static_cast<int>(mode);
    EXPECT_LE(computeBudgetUs(mode, 4, 4), 780) << static_cast<int>(mode) << ", thesis records";
  }
  EXPECT_EQ(computeBudgetUs(OutputMode::kForce, 4, 4), computeBudgetUs(OutputMode::kForce, 0, 4))
      << "thesis records: v2's budget, no time of their own (was 4 x 90 us, before that 4 x 225 us)";
}

// Armed, a console line starts only early enough to end before the read does.
TEST(FlyRules, AConsoleLineStartsOnlyWellBeforeTheReadUnlessTheReadLeavesNoRoom) {
  const uint16_t phase = readPhaseUs(computeBudgetUs(OutputMode::kForce, 0, 4));
  EXPECT_TRUE(consoleMayStart(0, phase));
  EXPECT_TRUE(consoleMayStart(static_cast<uint16_t>(phase - kConsoleSliceUs - 1), phase));
  EXPECT_FALSE(consoleMayStart(static_cast<uint16_t>(phase - kConsoleSliceUs), phase));
  EXPECT_FALSE(consoleMayStart(phase, phase)) << "the read and the computation";
  EXPECT_FALSE(consoleMayStart(kFrameUs - 1, phase));
  // a budget that starts the read too early for a window before it: lines come whenever
  const uint16_t early = readPhaseUs(static_cast<uint16_t>(kFrameUs - kImuReadUs - kMinPhaseUs - kConsoleSliceUs + 1));
  ASSERT_LT(early, kMinPhaseUs + kConsoleSliceUs);
  for (uint16_t t = 0; t < kFrameUs; t += 100) EXPECT_TRUE(consoleMayStart(t, early)) << t;
}

TEST(FlyRules, EachSlowJobRunsFiftyTimesASecondOnAFrameOfItsOwn) {  // one job per frame: slowJob()
  int count[6] = {};
  for (uint32_t frame = 0; frame < kLoopHz; ++frame) ++count[static_cast<int>(slowJob(frame))];
  EXPECT_EQ(slowJob(1), SlowJob::kBatteryModel) << "the frame after the battery's reading";
  EXPECT_EQ(count[static_cast<int>(SlowJob::kBattery)], 50);
  EXPECT_EQ(count[static_cast<int>(SlowJob::kBatteryModel)], 50);
  EXPECT_EQ(count[static_cast<int>(SlowJob::kStreamRow)], 50);
  EXPECT_EQ(count[static_cast<int>(SlowJob::kRollCorrection)], 50);
  EXPECT_EQ(count[static_cast<int>(SlowJob::kPitchCorrection)], 50);
  EXPECT_FLOAT_EQ(kSlowCycleS, 0.02f);
}

TEST(FlyRules, TheCollectiveSpoolsUpLinearlyOverOneSecondInIntegers) {
  const ForceDg full = 3000;  // 300 g
  EXPECT_EQ(spooledForce(full, 0), 0);
  EXPECT_EQ(spooledForce(full, 250), 750);
  EXPECT_EQ(spooledForce(full, 500), 1500);
  for (uint32_t ms = 0; ms < kSpoolMs; ms += 7)
    EXPECT_NEAR(spooledForce(full, ms), full * (ms / 1000.0), 3.0) << ms;  // within 1/1024 of it
  EXPECT_LT(spooledForce(full, kSpoolMs - 1), full);
  EXPECT_EQ(spooledForce(full, kSpoolMs), full);
  EXPECT_EQ(spooledForce(full, 60000), full);
}

// Every count of frames derives from the one loop rate.
TEST(FlyRules, FrameCountsDeriveFromTheLoopRate) {
  EXPECT_EQ(kFrameUs * kLoopHz, 1000000u);
  EXPECT_EQ(framesIn(1000), kLoopHz);
  EXPECT_EQ(framesIn(20), 8) << "at 400 Hz";
  EXPECT_EQ(framesIn(1), 1) << "rounded up";
  EXPECT_EQ(msOfFrames(kLoopHz), 1000u);
  EXPECT_EQ(kSlowCycleFrames * kSlowJobHz, kLoopHz);
}

}  // namespace

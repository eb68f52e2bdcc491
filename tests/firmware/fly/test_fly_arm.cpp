// fly's `arm` line on the fake HAL: when its reply comes, against the frames it arms.
#include <gtest/gtest.h>

#include <string>

#include "fly_fixture.hpp"

namespace {

using namespace fly_test;

// `arm`'s reply (~1 ms of formatting and printing on the chip) waits for the first flown frame:
// printed in the pass that takes the line, it ran across that frame's read and held the frame's
// computation up (thrustcal bench fly).
TEST_F(Fly, ArmAnswersAfterTheFirstFlownFrame) {
  // given
  storeFourV2Motors();
  bootReady();
  fake::takeOutput();

  // when: the loop's passes until the one that takes the line and arms
  fake::feedInput("arm\n");
  for (int pass = 0; pass < 1000 && !app_->armed(); ++pass) {
    hal::Clock::sleepUnless(&fly::FlyApp::hasWork);
    app_->runOnce();
  }
  ASSERT_TRUE(app_->armed()) << fake::output();
  const std::string at_arm = fake::takeOutput();

  // then: armed, not yet answered; the reply and the prompt come after the next frame
  EXPECT_FALSE(contains(at_arm, "armed:")) << at_arm;
  runFor(10);
  const std::string after = fake::takeOutput();
  EXPECT_TRUE(contains(after, "armed: mode force, layout x")) << after;
  EXPECT_NE(after.find("fly> ", after.find("armed:")), std::string::npos) << "the prompt after the reply";
}

}  // namespace

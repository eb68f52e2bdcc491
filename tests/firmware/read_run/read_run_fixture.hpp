// Shared by the read_run host tests: a fixture that boots read_run as main.cpp does and runs its
// loop on simulated time. The plant and the records it flies: records_fixture.hpp
// (tests/firmware/common).
#pragma once
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "hal/fake.hpp"
#include "hal/hal.hpp"
#include "read_run_app.hpp"
#include "records_fixture.hpp"

namespace rr_test {

using namespace records_test;  // the plant, the record builders and the text helpers
namespace fake = hal::fake;

// The v2 tests' four motors (the plant's gain): ~650 g at 2000 us, 11.3 V.
inline constexpr double kPlantK[rr::kMotors] = {6.0, 5.5, 6.5, 7.0};  // g/V^2

class ReadRun : public ::testing::Test {
 protected:
  void SetUp() override {
    fake::reset();
    fake::setTimeLimitMs(120000);  // a wait that never ends fails the test instead of hanging
    fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
  }

  void TearDown() override { fake::setTickHook(nullptr); }

  void storeFourMotors() {
    storeMotor(0, {13.5, true, 0});
    storeMotor(1, {12.0, true, 0});
    storeMotor(2, {15.0, true, 0});
    storeMotor(3, {14.0, true, 0});
  }

  // main.cpp's sequence up to the loop: init, banner, load, arm.
  void boot() {
    app_ = std::make_unique<rr::ReadRunApp>();
    hal::Esc::init(hal::kEscDefaultFrameHz);
    hal::Clock::init();
    hal::Uart::init(hal::kUartBaud);
    hal::Adc::init();
    app_->printBanner();
    calibrated_ = app_->loadCalibration();
    app_->arm();
  }

  // main.cpp's loop for `ms` simulated milliseconds. With keep_alive, an empty line every
  // 200 ms stands in for a host that keeps the failsafe from tripping.
  void runFor(uint32_t ms, bool keep_alive = false) {
    const uint32_t end_ms = fake::nowMs() + ms;
    app_->runOnce();
    while (fake::nowMs() < end_ms) {
      hal::Clock::sleepUntilInterrupt();
      if (keep_alive && fake::nowMs() % 200 == 0) fake::feedInput("\n");
      app_->runOnce();
    }
  }

  // Sends one command line and lets the loop handle it and run two frames.
  std::string command(const std::string& line, bool keep_alive = true) {
    fake::takeOutput();
    fake::feedInput(line + "\n");
    runFor(50, keep_alive);
    return fake::takeOutput();
  }

  uint16_t pulse(uint8_t motor) const { return fake::pulseUs(motor); }

  std::unique_ptr<rr::ReadRunApp> app_;
  uint8_t calibrated_ = 0;
};

}  // namespace rr_test

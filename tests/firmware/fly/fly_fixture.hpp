// Shared by fly's host tests: an MPU-6050 on the fake TWI whose truth the test sets, and a
// fixture that boots fly as main.cpp does and runs its loop on simulated time (the records the
// motors fly come from tests/firmware/common/records_fixture.hpp).
#pragma once
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <string>

#include "fly_app.hpp"
#include "params.hpp"
#include "hal/fake.hpp"
#include "hal/hal.hpp"
#include "records_fixture.hpp"

namespace fly_test {

using namespace records_test;
namespace fake = hal::fake;

// The IMU as fly configures it (+-2000 deg/s, +-8 g), mounted x forward, y left, z up. Every
// read gets the truth of that moment with DATA_RDY set, unless frozen; tick() moves the
// attitude by the rates (Euler rates: the test's truth, not a rigid body).
struct FakeImu {
  double roll_deg = 0, pitch_deg = 0;
  double rate_dps[3] = {0, 0, 0};
  int16_t gyro_bias_lsb[3] = {37, -21, 8};
  int16_t accel_offset_lsb[3] = {0, 0, 0};  // zero-g offsets (the datasheet allows +-50 mg on x, y)
  bool frozen = false;

  void attach(uint8_t who_am_i = 0x68) {
    fake::twiAttach(hal::kImuI2cAddress);
    fake::twiClearOnRead(0x3A);  // INT_STATUS clears on read
    fake::twiRegisters()[0x75] = who_am_i;
    fake::twiRegisters()[0x6B] = 0x40;  // asleep, as after power-up
    fake::setTwiReadHook([this](uint8_t, uint8_t) { refresh(); });
  }
  void tick() {
    roll_deg += rate_dps[0] * 0.001;
    pitch_deg += rate_dps[1] * 0.001;
  }
  void refresh() {
    if (frozen) return;
    const double d = M_PI / 180.0, r = roll_deg * d, p = pitch_deg * d;
    const double a[3] = {-std::sin(p), std::sin(r) * std::cos(p), std::cos(r) * std::cos(p)};
    uint8_t* regs = fake::twiRegisters();
    for (int i = 0; i < 3; ++i) {
      put(regs, 0x3B + 2 * i, std::lround(a[i] * 4096.0) + accel_offset_lsb[i]);
      put(regs, 0x43 + 2 * i, std::lround(rate_dps[i] * 16.4) + gyro_bias_lsb[i]);
    }
    put(regs, 0x41, std::lround((25.0 - 36.53) * 340.0));
    regs[0x3A] |= 0x01;  // DATA_RDY
  }
  static void put(uint8_t* regs, int reg, long value) {
    const auto v = static_cast<uint16_t>(static_cast<int16_t>(value));
    regs[reg] = static_cast<uint8_t>(v >> 8);
    regs[reg + 1] = static_cast<uint8_t>(v & 0xFF);
  }
};

class Fly : public ::testing::Test {
 protected:
  void SetUp() override {
    fake::reset();
    fake::setTimeLimitMs(120000);  // a wait that never ends fails the test instead of hanging
    fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
    imu_.attach();
    fake::setTickHook([this](uint32_t) { imu_.tick(); });
  }
  void TearDown() override {
    fake::setTickHook(nullptr);
    fake::setTwiReadHook(nullptr);
  }

  void storeFourThesisMotors() {
    storeMotor(0, {13.5, true, 0});
    storeMotor(1, {12.0, true, 0});
    storeMotor(2, {15.0, true, 0});
    storeMotor(3, {14.0, true, 0});
  }
  void storeFourV2Motors() {
    const uint16_t rest_mv = mvFromCounts(kCountsV1);
    const double k[4] = {13.5, 12.0, 15.0, 14.0};
    for (uint8_t i = 0; i < 4; ++i) storeV2Motor(i, k[i], rest_mv);
  }

  // main.cpp up to its loop.
  void boot() {
    app_ = std::make_unique<fly::FlyApp>();
    hal::Esc::init(fly::kLoopHz);
    hal::Clock::init();
    hal::Uart::init(hal::kUartBaud);
    hal::Adc::init();
    hal::Twi::init(hal::kTwiFastHz);
    hal::Watchdog::start();
    app_->printBanner();
    calibrated_ = app_->loadCalibration();
    app_->start();
    fly::Params::load(*app_);
    app_->startImu();
    app_->calibrateGyro();
  }
  // boot(), then the loop until the ESCs' arming time is over (fly can arm from then on).
  void bootReady() {
    boot();
    runFor(tc::kArmMs + 10 - fake::nowMs());
    fake::takeOutput();
  }

  // main.cpp's loop for `ms` simulated milliseconds; with keep_alive, an empty line every
  // 200 ms stands in for a host that keeps the link up.
  void runFor(uint32_t ms, bool keep_alive = true) {
    const uint32_t end_ms = fake::nowMs() + ms;
    app_->runOnce();
    int passes_at_once = 0;  // passes with no time between: the loop never sleeps (a bug)
    while (fake::nowMs() < end_ms) {
      const uint32_t before_ms = fake::nowMs();
      hal::Clock::sleepUnless(&fly::FlyApp::hasWork);
      passes_at_once = fake::nowMs() == before_ms ? passes_at_once + 1 : 0;
      ASSERT_LT(passes_at_once, 100) << "the loop has work forever at " << before_ms << " ms";
      if (keep_alive && fake::nowMs() % 200 == 0 && fake::nowMs() != before_ms) fake::feedInput("\n");
      app_->runOnce();
    }
  }
  // The loop until `done` holds (checked every millisecond) or `max_ms` passed; the time taken.
  uint32_t runUntil(const std::function<bool()>& done, uint32_t max_ms, bool keep_alive = true) {
    const uint32_t from_ms = fake::nowMs();
    while (!done() && fake::nowMs() - from_ms < max_ms) runFor(1, keep_alive);
    return fake::nowMs() - from_ms;
  }

  // One command line, handled, and 20 ms of frames after it.
  std::string command(const std::string& line) {
    fake::takeOutput();
    fake::feedInput(line + "\n");
    runFor(20);
    return fake::takeOutput();
  }
  // Arms and spools up (thrust in grams over the layout's motors).
  void armAndSpool(uint16_t thrust_g) {
    ASSERT_TRUE(contains(command("thrust " + std::to_string(thrust_g)), "thrust: ")) << fake::output();
    const std::string out = command("arm");
    ASSERT_TRUE(app_->armed()) << out;
    runFor(fly::kSpoolMs + 20);
  }

  uint16_t pulse(uint8_t motor) const { return fake::pulseUs(motor); }
  bool allStopped() const {
    for (uint8_t i = 0; i < 4; ++i) {
      if (pulse(i) != tc::kStopPwmUs) return false;
    }
    return true;
  }

  FakeImu imu_;
  std::unique_ptr<fly::FlyApp> app_;
  uint8_t calibrated_ = 0;
};

}  // namespace fly_test

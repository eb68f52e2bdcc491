// The words and numbers fly's console view is made of (fly_view_parts.hpp).
#include "fly_view_parts.hpp"

#include "slot_report.hpp"

namespace fly {
namespace view {

using fw::newline;
using fw::say;
using fw::sayLine;


// Numbers: 16 bits where they fit (printFixed16, no 32-bit division: status runs beside the
// frames, which only get the CPU back between lines or when the transmit ring is full).
void sayFixed(int32_t value, uint8_t decimals) {
  if (value >= -32768 && value <= 32767) {
    fw::printFixed16(static_cast<int16_t>(value), decimals);
  } else {
    fw::printFixed(value, decimals);
  }
}
void sayCount(uint32_t value) { sayFixed(value > 0x7FFFFFFFu ? 0x7FFFFFFF : static_cast<int32_t>(value), 0); }
// A float with `decimals` decimals, rounded.
void sayFloat(float v, uint8_t decimals) {
  float scale = 1.0f;
  for (uint8_t i = 0; i < decimals; ++i) scale *= 10.0f;
  const float x = v * scale;
  const float limit = 2.0e9f;
  sayFixed(static_cast<int32_t>(x > limit ? limit : (x < -limit ? -limit : x + (x < 0 ? -0.5f : 0.5f))),
           decimals);
}
void sayDeg(float rad) { sayFloat(rad * kDegPerRad, 1); }
void sayMilli(float v) { sayCount(static_cast<uint32_t>(v * 1000.0f + 0.5f)); }

namespace {
const char* faultText(ImuFault fault) {
  switch (fault) {
    case ImuFault::kNoAnswer:
      return TC_FLASH_TEXT("no answer at its address (wiring: SDA D20, SCL D21, 3.3 V, pull-ups)");
    case ImuFault::kWrongId:
      return TC_FLASH_TEXT("WHO_AM_I is not 0x68 (not an MPU-6050?): read 0x");
    case ImuFault::kBusStuck:
      return TC_FLASH_TEXT("the bus is stuck (a line held low)");
    case ImuFault::kBadConfig:
      return TC_FLASH_TEXT("its settings did not read back");
    case ImuFault::kFrozen:
      return TC_FLASH_TEXT("frozen data (no new sample in ");
    case ImuFault::kNone:
      break;
  }
  return TC_FLASH_TEXT("none");
}

}  // namespace

void sayFault(const Mpu6050& imu) {
  say(faultText(imu.fault()));
  if (imu.fault() == ImuFault::kWrongId) fw::printHex2(imu.whoAmI());
  if (imu.fault() == ImuFault::kFrozen) {
    sayCount(kImuMaxStaleReads);
    say(TC_FLASH_TEXT(" reads)"));
  }
  if (imu.fault() != ImuFault::kBusStuck) return;
  if (imu.lastStatus() == Mpu6050::kTimedOut) {
    say(TC_FLASH_TEXT(": a transfer never ended"));
  } else {
    say(TC_FLASH_TEXT(", TWI status 0x"));
    fw::printHex2(imu.lastStatus());
  }
}

const char* modeName(OutputMode mode) {
  switch (mode) {
    case OutputMode::kGeneric:
      return TC_FLASH_TEXT("generic");
    case OutputMode::kPwm:
      return TC_FLASH_TEXT("pwm");
    case OutputMode::kArduPilot:
      return TC_FLASH_TEXT("ardupilot");
    case OutputMode::kForce:
      break;
  }
  return TC_FLASH_TEXT("force");
}

const char* layoutName(Layout layout) {
  switch (layout) {
    case Layout::kPlus:
      return TC_FLASH_TEXT("plus");
    case Layout::kSeesaw:
      return TC_FLASH_TEXT("seesaw");
    case Layout::kX:
      break;
  }
  return TC_FLASH_TEXT("x");
}

void sayMs(uint32_t ms) {
  sayCount(ms);
  say(TC_FLASH_TEXT(" ms"));
}

void sayFrameLayout(const FlyApp& app) {
  say(TC_FLASH_TEXT("IMU read at "));
  sayCount(app.loopStats().phase_us);
  say(TC_FLASH_TEXT(" us of each "));
  sayCount(kFrameUs);
  say(TC_FLASH_TEXT(" us frame, computation budget "));
  sayCount(app.loopStats().budget_us);
  say(TC_FLASH_TEXT(" us"));
}

// "motor N" and the first motor of the layout that cannot fly in this mode.
void sayUnflyableMotor(const FlyApp& app) {
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (!app.mixer().flies(i) || app.motors().isArmable(i)) continue;
    const fw::Motor& source = app.motors().motor(app.motors().motor(i).source);
    fw::sayMotor(i);
    say(TC_FLASH_TEXT(" is "));
    fw::sayRecordStatus(source);
    say(TC_FLASH_TEXT("; calibrate it with gather_store, or fly mode generic N"));
    return;
  }
}


}  // namespace view
}  // namespace fly

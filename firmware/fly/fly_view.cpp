// fly's console view (fly_view.hpp): what the image prints, nothing it decides. `status` and the
// stream rows are in fly_status_view.cpp; the words and numbers both use in fly_view_parts.cpp.
#include "fly_view.hpp"

#include "fly_view_parts.hpp"
#include "slot_report.hpp"

namespace fly {
namespace view {

using fw::newline;
using fw::say;
using fw::sayLine;

void banner() {
  newline();
  sayLine(TC_FLASH_TEXT("fly: attitude control on calibrated actuators (thrustcal, issue 19)"));
  fw::printResetCause();
  say(TC_FLASH_TEXT("type help for commands; while armed send a line at least every "));
  sayMs(tc::kFailsafeMs);
  newline();
}

void imuStarted(const Mpu6050& imu) {
  if (imu.running()) {
    say(TC_FLASH_TEXT("imu: MPU-6050 at 0x"));
    fw::printHex2(hal::kImuI2cAddress);
    say(TC_FLASH_TEXT(", WHO_AM_I 0x"));
    fw::printHex2(imu.whoAmI());
    sayLine(TC_FLASH_TEXT("; 1 kHz, 98 Hz low-pass, +-2000 deg/s, +-8 g, read every frame"));
    return;
  }
  say(TC_FLASH_TEXT("imu: error: "));
  sayFault(imu);
  sayLine(TC_FLASH_TEXT("; arming is refused; it tries again every second"));
}

void imuFault(const Mpu6050& imu) {
  say(TC_FLASH_TEXT("imu: fault: "));
  sayFault(imu);
  sayLine(TC_FLASH_TEXT("; it tries again every second"));
}

void imuRunningAgain() {
  sayLine(TC_FLASH_TEXT("imu: running again; measuring the gyro bias (keep it still)"));
}

void calibrating() {
  say(TC_FLASH_TEXT("imu: measuring the gyro bias: keep the vehicle still ("));
  sayMs(static_cast<uint32_t>(GyroCalibration::kSamples) * 1000u / kLoopHz);  // 32 bits
  sayLine(TC_FLASH_TEXT(")"));
}

void calibrationResult(const FlyApp& app) {
  const GyroCalibration& c = app.gyroCalibration();
  if (!c.done()) {
    say(TC_FLASH_TEXT("imu: gyro not calibrated yet (motion seen "));
    sayCount(c.restarts());
    sayLine(TC_FLASH_TEXT(" times): keep it still; arm waits for it"));
    return;
  }
  say(TC_FLASH_TEXT("imu: gyro bias"));
  for (uint8_t i = 0; i < 3; ++i) {
    hal::Uart::write(' ');
    sayFloat(c.biasLsb(i) / kGyroLsbPerDps, 2);
  }
  say(TC_FLASH_TEXT(" deg/s; roll "));
  sayDeg(app.attitude().roll_rad);
  say(TC_FLASH_TEXT(" pitch "));
  sayDeg(app.attitude().pitch_rad);
  sayLine(TC_FLASH_TEXT(" deg"));
}

// "x 39.1 y -17.8 z 14.6" in mg, from LSB (kAccelLsbPerG a g).
void sayMilliG(const float lsb[3]) {
  for (uint8_t i = 0; i < 3; ++i) {
    hal::Uart::write(' ');
    hal::Uart::write(static_cast<char>('x' + i));
    hal::Uart::write(' ');
    sayFloat(lsb[i] * (1000.0f / static_cast<float>(kAccelLsbPerG)), 1);
  }
}

void levelResult(const FlyApp& app) {
  float lsb[3];
  if (app.levelTrimmed()) {
    for (uint8_t i = 0; i < 3; ++i) lsb[i] = app.estimator().levelTrimLsb(i);
    say(TC_FLASH_TEXT("level: accelerometer trim"));
    sayMilliG(lsb);
    sayLine(TC_FLASH_TEXT(" mg: this attitude is level from now on"));
    return;
  }
  const GyroCalibration& c = app.gyroCalibration();
  for (uint8_t i = 0; i < 3; ++i) lsb[i] = c.accelMeanLsb(i) - (i == 2 ? static_cast<float>(kAccelLsbPerG) : 0.0f);
  say(TC_FLASH_TEXT("error: level refused: off level the accelerometer reads"));
  sayMilliG(lsb);
  say(TC_FLASH_TEXT(" mg, over "));
  sayFloat(AttitudeEstimator::kMaxLevelTrimLsb * (1000.0f / static_cast<float>(kAccelLsbPerG)), 0);
  sayLine(TC_FLASH_TEXT(" mg: stand the vehicle level and try again (trim kept)"));
}

void armRefused(ArmRefusal why, const FlyApp& app) {
  const ArmInputs in = app.armInputs();
  say(TC_FLASH_TEXT("error: arm refused: "));
  switch (why) {
    case ArmRefusal::kArmed:
      say(TC_FLASH_TEXT("armed already"));
      break;
    case ArmRefusal::kEscsArming:
      say(TC_FLASH_TEXT("the ESCs are still arming (their first 2 s at the stop pulse)"));
      break;
    case ArmRefusal::kImuFault:
      say(TC_FLASH_TEXT("IMU fault: "));
      sayFault(app.imu());
      break;
    case ArmRefusal::kImuStarting:
      say(TC_FLASH_TEXT("the IMU is starting or its gyro is being calibrated (keep it still)"));
      break;
    case ArmRefusal::kNotLevel:
      say(TC_FLASH_TEXT("not level: roll "));
      sayFloat(in.roll_deg, 1);
      say(TC_FLASH_TEXT(" pitch "));
      sayFloat(in.pitch_deg, 1);
      say(TC_FLASH_TEXT(" deg (both within "));
      sayCount(static_cast<uint32_t>(kArmLevelDeg));
      say(TC_FLASH_TEXT(")"));
      break;
    case ArmRefusal::kMoving:
      say(TC_FLASH_TEXT("moving: rates"));
      for (uint8_t i = 0; i < 3; ++i) {
        hal::Uart::write(' ');
        sayFloat(in.rate_dps[i], 1);
      }
      say(TC_FLASH_TEXT(" deg/s (all below "));
      sayCount(static_cast<uint32_t>(kArmStillDps));
      say(TC_FLASH_TEXT(")"));
      break;
    case ArmRefusal::kMotorNotCalibrated:
      sayUnflyableMotor(app);
      break;
    case ArmRefusal::kModeNeedsSettings:
      say(app.output().mode() == OutputMode::kPwm
              ? TC_FLASH_TEXT("mode pwm needs its hover point: hover US MG_PER_US")
              : TC_FLASH_TEXT(
                    "mode ardupilot needs its parameters: ap EXPO_E4 SPIN_MIN_E4 SPIN_MAX_E4 FULL_G"));
      break;
    case ArmRefusal::kNone:
      break;
  }
  newline();
}

void armed(const FlyApp& app) {
  const bool sticks = app.flight().source == ArmSource::kSticks;
  say(TC_FLASH_TEXT("armed: mode "));
  say(modeName(app.output().mode()));
  say(TC_FLASH_TEXT(", layout "));
  say(layoutName(app.mixer().layout()));
  if (sticks) {
    say(TC_FLASH_TEXT(", from the sticks; spooling up for "));
    sayMs(kSpoolMs);
    say(TC_FLASH_TEXT("; the receiver's failsafe: "));
    sayMs(kRcLossMs);
    sayLine(TC_FLASH_TEXT(" without a frame"));
    return;
  }
  say(TC_FLASH_TEXT(", thrust "));
  sayCount(static_cast<uint32_t>(app.settings().thrust_g));
  say(TC_FLASH_TEXT(" g; spooling up for "));
  sayMs(kSpoolMs);
  say(TC_FLASH_TEXT("; send a line at least every "));
  sayMs(tc::kFailsafeMs);
  newline();
}

void stickArm(const FlyApp& app) {
  const ArmRefusal why = app.receiver().refused;
  if (why == ArmRefusal::kNone) {
    armed(app);
    return;
  }
  say(TC_FLASH_TEXT("sticks: "));
  armRefused(why, app);
}

void disarmed(const FlyApp& app) {
  const FlightState& f = app.flight();
  say(TC_FLASH_TEXT("disarmed: "));
  switch (f.last_cause) {
    case DisarmCause::kCrash:
      say(TC_FLASH_TEXT("crash (attitude "));
      sayFloat(f.cause_deg, 1);
      say(TC_FLASH_TEXT(" deg beyond "));
      sayCount(app.settings().crash_deg);
      say(TC_FLASH_TEXT(")"));
      break;
    case DisarmCause::kImu:
      say(TC_FLASH_TEXT("IMU fault ("));
      sayFault(app.imu());
      say(TC_FLASH_TEXT(")"));
      break;
    case DisarmCause::kLink:
      say(TC_FLASH_TEXT("link lost (no line for "));
      sayMs(tc::kFailsafeMs);
      say(TC_FLASH_TEXT(")"));
      break;
    case DisarmCause::kRcLost:
      say(TC_FLASH_TEXT("receiver lost (no valid frame for "));
      sayMs(kRcLossMs);
      say(TC_FLASH_TEXT(")"));
      break;
    case DisarmCause::kSticks:
      say(TC_FLASH_TEXT("sticks (throttle low, yaw left)"));
      break;
    default:
      say(TC_FLASH_TEXT("command"));
      break;
  }
  sayLine(TC_FLASH_TEXT("; every ESC at the stop pulse until the next arm"));
}

void setpoint(const FlyApp& app) {
  say(TC_FLASH_TEXT("setpoint: roll "));
  sayDeg(app.command().setpoint.roll_rad);
  say(TC_FLASH_TEXT(" pitch "));
  sayDeg(app.command().setpoint.pitch_rad);
  sayLine(TC_FLASH_TEXT(" deg"));
}

void thrust(const FlyApp& app) {
  say(TC_FLASH_TEXT("thrust: "));
  sayCount(static_cast<uint32_t>(app.settings().thrust_g));
  say(TC_FLASH_TEXT(" g over "));
  sayCount(app.mixer().motorCount());
  say(TC_FLASH_TEXT(" motors"));
  if (app.output().mode() == OutputMode::kPwm)
    say(TC_FLASH_TEXT(" (mode pwm flies its hover pulse instead)"));
  newline();
}

void gains(const FlyApp& app) {
  const AxisGains& g = app.controller().settings().angle;
  const YawGains& y = app.controller().settings().yaw;
  say(TC_FLASH_TEXT("gains: roll/pitch kp "));
  sayMilli(g.kp_nm_per_rad);
  say(TC_FLASH_TEXT(" ki "));
  sayMilli(g.ki_nm_per_rad_s);
  say(TC_FLASH_TEXT(" kd "));
  sayMilli(g.kd_nm_s_per_rad);
  say(TC_FLASH_TEXT(", yaw kp "));
  sayMilli(y.kp_nm_s_per_rad);
  say(TC_FLASH_TEXT(" ki "));
  sayMilli(y.ki_nm_per_rad);
  sayLine(TC_FLASH_TEXT(" (mN m)"));
}

void mode(const FlyApp& app) {
  const OutputStage& out = app.output();
  say(TC_FLASH_TEXT("mode: "));
  say(modeName(out.mode()));
  if (out.mode() == OutputMode::kGeneric) {
    say(TC_FLASH_TEXT(" (slot "));
    sayCount(out.genericSlot());
    say(TC_FLASH_TEXT("'s record for every motor)"));
  }
  say(TC_FLASH_TEXT("; "));
  sayFrameLayout(app);
  newline();
}

void genericSlotRefused(uint8_t slot, const fw::Motor& m) {
  say(TC_FLASH_TEXT("error: slot "));
  sayCount(slot);
  say(TC_FLASH_TEXT(" is "));
  fw::sayRecordStatus(m);
  sayLine(TC_FLASH_TEXT("; generic mode needs a calibrated slot"));
}

void layout(const FlyApp& app) {
  say(TC_FLASH_TEXT("layout: "));
  say(layoutName(app.mixer().layout()));
  say(TC_FLASH_TEXT(", arm "));
  sayMilli(app.mixer().settings().arm_m);
  say(TC_FLASH_TEXT(" mm, yaw arm "));
  sayCount(static_cast<uint32_t>(app.mixer().settings().yaw_arm_m * 1.0e6f + 0.5f));
  say(TC_FLASH_TEXT(" um, motors "));
  say(app.mixer().layout() == Layout::kSeesaw ? TC_FLASH_TEXT("0 (left) and 1 (right)")
                                              : TC_FLASH_TEXT("0..3"));
  newline();
}

void hover(const FlyApp& app) {
  const PwmModeParams& p = app.output().pwmParams();
  say(TC_FLASH_TEXT("hover: "));
  sayCount(p.hover_us);
  say(TC_FLASH_TEXT(" us, "));
  sayFloat(p.slope_g_per_us, 3);
  sayLine(TC_FLASH_TEXT(" g per us"));
}

void arduPilot(const FlyApp& app) {
  const ArduPilotParams& p = app.output().arduPilot().params();
  say(TC_FLASH_TEXT("ardupilot: MOT_THST_EXPO "));
  sayFloat(p.expo, 4);
  say(TC_FLASH_TEXT(" MOT_SPIN_MIN "));
  sayFloat(p.spin_min, 4);
  say(TC_FLASH_TEXT(" MOT_SPIN_MAX "));
  sayFloat(p.spin_max, 4);
  say(TC_FLASH_TEXT(" MOT_PWM "));
  sayCount(p.pwm_min_us);
  say(TC_FLASH_TEXT(".."));
  sayCount(p.pwm_max_us);
  say(TC_FLASH_TEXT(" MOT_BAT_VOLT "));
  sayFloat(p.bat_volt_max_v, 2);
  say(TC_FLASH_TEXT(".."));
  sayFloat(p.bat_volt_min_v, 2);
  say(TC_FLASH_TEXT(" full thrust "));
  sayCount(static_cast<uint32_t>(p.full_thrust_g));
  sayLine(TC_FLASH_TEXT(" g"));
}

void crashLimit(const FlyApp& app) {
  say(TC_FLASH_TEXT("crash: disarm beyond "));
  sayCount(app.settings().crash_deg);
  sayLine(TC_FLASH_TEXT(" deg of roll or pitch"));
}

namespace {
const char* protocolName(RcProtocol p) {
  switch (p) {
    case RcProtocol::kPpm:
      return TC_FLASH_TEXT("ppm (a PPM sum on A8)");
    case RcProtocol::kPwm:
      return TC_FLASH_TEXT("pwm (a pulse per channel from A8)");
    case RcProtocol::kOff:
      break;
  }
  return TC_FLASH_TEXT("off");
}
}  // namespace

void receiver(const FlyApp& app) {
  const RcSettings& s = app.rcSettings();
  const StickSettings& k = app.stickCommand().settings();
  say(TC_FLASH_TEXT("rc: "));
  say(protocolName(s.protocol));
  if (s.protocol == RcProtocol::kPwm) {
    say(TC_FLASH_TEXT(", "));
    sayCount(s.pwm_channels);
    say(TC_FLASH_TEXT(" channels"));
  }
  say(TC_FLASH_TEXT(", map "));
  hal::Uart::print(s.map);
  say(TC_FLASH_TEXT(", channel 5 angle|rate (without it "));
  say(s.default_mode == FlightMode::kRate ? TC_FLASH_TEXT("rate") : TC_FLASH_TEXT("angle"));
  say(TC_FLASH_TEXT("); full stick "));
  sayCount(k.max_angle_deg);
  say(TC_FLASH_TEXT(" deg, "));
  sayCount(k.max_rate_dps);
  say(TC_FLASH_TEXT(" deg/s, yaw "));
  sayCount(k.max_yaw_rate_dps);
  sayLine(TC_FLASH_TEXT(" deg/s"));
}

void helpFooter() {
  say(TC_FLASH_TEXT("arming: a complete arm line (or the sticks held "));
  sayMs(kStickHoldMs);
  sayLine(TC_FLASH_TEXT("), level within"));
  sayCount(static_cast<uint32_t>(kArmLevelDeg));
  say(TC_FLASH_TEXT(" deg, rates below "));
  sayCount(static_cast<uint32_t>(kArmStillDps));
  sayLine(TC_FLASH_TEXT(" deg/s, IMU running and calibrated, ESCs armed,"));
  sayLine(TC_FLASH_TEXT("the layout's motors flyable"));
  say(TC_FLASH_TEXT("disarms: roll or pitch beyond the crash limit, an IMU fault; armed by a"));
  newline();
  say(TC_FLASH_TEXT("line: "));
  sayMs(tc::kFailsafeMs);
  sayLine(TC_FLASH_TEXT(" without a line (an empty line will do; with strict on a"));
  say(TC_FLASH_TEXT("checksummed one, e.g. *00); armed by the sticks: "));
  sayMs(kRcLossMs);
  sayLine(TC_FLASH_TEXT(" without a valid"));
  sayLine(TC_FLASH_TEXT("receiver frame"));
  say(TC_FLASH_TEXT("lines: CR, LF or CRLF, at most "));
  sayCount(fw::kLineMax);
  sayLine(TC_FLASH_TEXT(" characters; optional checksum *HH = XOR"));
  sayLine(TC_FLASH_TEXT("of the line before '*'; a damaged line is rejected whole (docs/console.md)"));
}


}  // namespace view
}  // namespace fly

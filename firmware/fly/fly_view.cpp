// fly's console view (fly_view.hpp): what the image prints, nothing it decides.
#include "fly_view.hpp"

#include "params.hpp"
#include "slot_report.hpp"

namespace fly {
namespace view {

namespace {

using fw::newline;
using fw::say;
using fw::sayLine;

constexpr float kDegPerRad = 180.0f / 3.14159265f;

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

}  // namespace

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
  sayMs(static_cast<uint32_t>(GyroCalibration::kSamples) * 1000u / kFrameHz);  // 32 bits: 400 000
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
    sayFloat(c.biasLsb(i) / mpu::kGyroLsbPerDps, 2);
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
    sayFloat(lsb[i] * (1000.0f / mpu::kAccelLsbPerG), 1);
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
  for (uint8_t i = 0; i < 3; ++i) lsb[i] = c.accelMeanLsb(i) - (i == 2 ? mpu::kAccelLsbPerG : 0.0f);
  say(TC_FLASH_TEXT("error: level refused: off level the accelerometer reads"));
  sayMilliG(lsb);
  say(TC_FLASH_TEXT(" mg, over "));
  sayFloat(AttitudeEstimator::kMaxLevelTrimLsb * (1000.0f / mpu::kAccelLsbPerG), 0);
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
  say(TC_FLASH_TEXT("armed: mode "));
  say(modeName(app.output().mode()));
  say(TC_FLASH_TEXT(", layout "));
  say(layoutName(app.mixer().layout()));
  say(TC_FLASH_TEXT(", thrust "));
  sayCount(static_cast<uint32_t>(app.settings().thrust_g));
  say(TC_FLASH_TEXT(" g; spooling up for "));
  sayMs(kSpoolMs);
  say(TC_FLASH_TEXT("; send a line at least every "));
  sayMs(tc::kFailsafeMs);
  newline();
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
    default:
      say(TC_FLASH_TEXT("command"));
      break;
  }
  sayLine(TC_FLASH_TEXT("; every ESC at the stop pulse until the next arm"));
}

void setpoint(const FlyApp& app) {
  say(TC_FLASH_TEXT("setpoint: roll "));
  sayDeg(app.settings().setpoint.roll_rad);
  say(TC_FLASH_TEXT(" pitch "));
  sayDeg(app.settings().setpoint.pitch_rad);
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
  const AxisGains& g = app.controller().gains();
  const YawGains& y = app.controller().yawGains();
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
  sayMilli(app.settings().arm_m);
  say(TC_FLASH_TEXT(" mm, yaw arm "));
  sayCount(static_cast<uint32_t>(app.settings().yaw_arm_m * 1.0e6f + 0.5f));
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

void statusState(const FlyApp& app) {
  say(app.flight().armed ? TC_FLASH_TEXT("state: armed") : TC_FLASH_TEXT("state: disarmed"));
  say(TC_FLASH_TEXT(", disarms "));
  sayCount(app.flight().disarms);
  say(TC_FLASH_TEXT(", mode "));
  say(modeName(app.output().mode()));
  say(TC_FLASH_TEXT(", layout "));
  say(layoutName(app.mixer().layout()));
  newline();
}

void statusImu(const FlyApp& app) {
  const Mpu6050& imu = app.imu();
  say(TC_FLASH_TEXT("imu: "));
  if (imu.fault() != ImuFault::kNone) {
    say(TC_FLASH_TEXT("fault: "));
    sayFault(imu);
  } else {
    say(imu.running() ? TC_FLASH_TEXT("running") : TC_FLASH_TEXT("starting"));
  }
  say(TC_FLASH_TEXT("; reads "));
  sayCount(imu.readsOk());
  say(TC_FLASH_TEXT(", bad in a row "));
  sayCount(imu.badReads());
  say(TC_FLASH_TEXT(", stale "));
  sayCount(imu.staleReads());
  say(TC_FLASH_TEXT(", faults "));
  sayCount(imu.faults());
  say(TC_FLASH_TEXT(", bus recoveries "));
  sayCount(imu.recoveries());
  say(app.gyroCalibration().done() ? TC_FLASH_TEXT(", gyro calibrated")
                                   : TC_FLASH_TEXT(", gyro not calibrated"));
  newline();
}

void statusAttitude(const FlyApp& app) {
  const Attitude a = app.attitude();
  say(TC_FLASH_TEXT("attitude: roll "));
  sayDeg(a.roll_rad);
  say(TC_FLASH_TEXT(" pitch "));
  sayDeg(a.pitch_rad);
  say(TC_FLASH_TEXT(" deg, rates"));
  for (uint8_t i = 0; i < 3; ++i) {
    hal::Uart::write(' ');
    sayDeg(a.rate_rad_s[i]);
  }
  sayLine(TC_FLASH_TEXT(" deg/s"));
}

void statusLoop(const FlyApp& app) {
  const LoopStats& s = app.loopStats();
  say(TC_FLASH_TEXT("loop: "));
  sayFrameLayout(app);
  say(TC_FLASH_TEXT("; armed: computation at most "));
  sayCount(s.compute_max_us);
  say(TC_FLASH_TEXT(" us, pulses written at least "));
  sayCount(s.margin_min_us == 0xFFFF ? 0 : s.margin_min_us);
  say(TC_FLASH_TEXT(" us before the edge, late "));
  sayCount(s.late);
  say(TC_FLASH_TEXT(", frames skipped "));
  sayCount(app.imu().skippedFrames());
  newline();
}

// What the integrators hold now (the mismatch they absorb; 0 without integral gains).
void statusIntegrators(const FlyApp& app) {
  say(TC_FLASH_TEXT("integrators: roll "));
  sayFloat(app.controller().integralNm(0) * 1000.0f, 1);
  say(TC_FLASH_TEXT(" pitch "));
  sayFloat(app.controller().integralNm(1) * 1000.0f, 1);
  say(TC_FLASH_TEXT(" yaw "));
  sayFloat(app.controller().integralNm(2) * 1000.0f, 1);
  sayLine(TC_FLASH_TEXT(" mN m"));
}

// "motor N: F g, P us; slot S (model v2)" and what keeps it from flying.
void statusMotor(const FlyApp& app, uint8_t i) {
  const fw::Motor& m = app.motors().motor(i);
  fw::sayMotor(i);
  say(TC_FLASH_TEXT(": "));
  sayFixed(roundedGrams(app.flight().force[i]), 0);
  say(TC_FLASH_TEXT(" g, "));
  sayCount(app.output().pulseUs(i));
  say(TC_FLASH_TEXT(" us; slot "));
  sayCount(m.source);
  say(TC_FLASH_TEXT(" "));
  if (app.motors().isArmable(i)) {
    say(app.motors().motor(m.source).fliesV2() ? TC_FLASH_TEXT("(model v2)")
                                               : TC_FLASH_TEXT("(thesis record)"));
  } else {
    fw::sayRecordStatus(app.motors().motor(m.source));
  }
  if (!app.mixer().flies(i)) say(TC_FLASH_TEXT(", not in this layout"));
  newline();
}

}  // namespace

// `yield` (not null) between the lines: the frames run there.
void status(const FlyApp& app, void (*yield)()) {
  statusState(app);
  yield();
  statusImu(app);
  yield();
  statusAttitude(app);
  yield();
  setpoint(app);
  thrust(app);
  yield();
  gains(app);
  crashLimit(app);
  yield();
  Params::sayStatus(app);
  yield();
  statusIntegrators(app);
  yield();
  statusLoop(app);
  for (uint8_t i = 0; i < kMotors; ++i) {
    yield();
    statusMotor(app, i);
  }
  yield();
  say(TC_FLASH_TEXT("battery "));
  fw::sayVolts(app.motors().batteryMv());
  say(TC_FLASH_TEXT(" raw; link failsafe trips "));
  sayCount(app.link().trips);
  newline();
  fw::printHealth(app.console(), yield);  // frames go on during the stack scan
}

void streamHeader() {
  sayLine(
      TC_FLASH_TEXT("t_s,roll_deg,pitch_deg,roll_sp_deg,pitch_sp_deg,p_dps,q_dps,r_dps,"
                    "force0_g,force1_g,force2_g,force3_g,pulse0_us,pulse1_us,pulse2_us,pulse3_us"));
}

// Every number 16 bits (printFixed16: no 32-bit division); the time as seconds and milliseconds.
void streamRow(const StreamRow& row) {
  const uint32_t seconds = row.t_ms / 1000u;
  if (seconds <= 32767u) {
    fw::printFixed16(static_cast<int16_t>(seconds), 0);
  } else {
    sayCount(seconds);
  }
  hal::Uart::write('.');
  const uint16_t ms = static_cast<uint16_t>(row.t_ms - seconds * 1000u);
  if (ms < 100) hal::Uart::write('0');
  if (ms < 10) hal::Uart::write('0');
  fw::printFixed16(static_cast<int16_t>(ms), 0);
  const int16_t cdeg[4] = {row.roll_cdeg, row.pitch_cdeg, row.roll_sp_cdeg, row.pitch_sp_cdeg};
  for (int16_t v : cdeg) {
    hal::Uart::write(',');
    fw::printFixed16(v, 2);
  }
  for (int16_t v : row.rate_ddps) {
    hal::Uart::write(',');
    fw::printFixed16(v, 1);
  }
  for (uint16_t v : row.force_g) {
    hal::Uart::write(',');
    fw::printFixed16(static_cast<int16_t>(v), 0);
  }
  for (uint16_t v : row.pulse_us) {
    hal::Uart::write(',');
    fw::printFixed16(static_cast<int16_t>(v), 0);
  }
  newline();
}

void helpFooter() {
  say(TC_FLASH_TEXT("arming: a complete arm line, level within "));
  sayCount(static_cast<uint32_t>(kArmLevelDeg));
  say(TC_FLASH_TEXT(" deg, rates below "));
  sayCount(static_cast<uint32_t>(kArmStillDps));
  sayLine(TC_FLASH_TEXT(" deg/s,"));
  sayLine(TC_FLASH_TEXT("IMU running and calibrated, ESCs armed, the layout's motors flyable"));
  say(TC_FLASH_TEXT("disarms: roll or pitch beyond the crash limit, an IMU fault, "));
  sayMs(tc::kFailsafeMs);
  newline();
  sayLine(TC_FLASH_TEXT("without a line (an empty line will do; with strict on a checksummed"));
  sayLine(TC_FLASH_TEXT("one, e.g. *00)"));
  say(TC_FLASH_TEXT("lines: CR, LF or CRLF, at most "));
  sayCount(fw::kLineMax);
  sayLine(TC_FLASH_TEXT(" characters; optional checksum *HH = XOR"));
  sayLine(TC_FLASH_TEXT("of the line before '*'; a damaged line is rejected whole (docs/console.md)"));
}

}  // namespace view
}  // namespace fly

// fly's console commands: one table in flash (fw::Command rows, firmware/common/shell.hpp), a
// one-call handler per row and the command methods they call. The shell parses and
// range-checks the arguments from the rows, refuses guarded rows without a checksum in strict
// mode and prints `help` from them. docs/fly.md holds the help text a host test compares with
// printHelp().
#include "dyn_console.hpp"
#include "eeprom_console.hpp"
#include "fly_app.hpp"
#include "fly_view.hpp"
#include "params.hpp"
#include "shell.hpp"

namespace fly {

using fw::sayLine;

namespace {
constexpr int8_t kMaxSetpointDeg = 30;
constexpr uint16_t kMaxThrustG = 4 * 2500;  // four motors of the heaviest class flown
}  // namespace

// The table's handlers: one call each, from the parsed arguments to the app's command (the
// shape of read_run's and gather_store's).
struct Commands {
  using App = FlyApp;
  using Args = fw::ArgValues;
  static uint16_t u16(int32_t v) { return static_cast<uint16_t>(v); }

  static void help(App&, const Args&) { App::printHelp(); }
  static void arm(App& app, const Args&) { app.cmdArm(); }
  static void disarm(App& app, const Args&) { app.cmdDisarm(); }
  static void setpoint(App& app, const Args& a) {
    app.cmdSetpoint(static_cast<int8_t>(a[0]), static_cast<int8_t>(a[1]));
  }
  static void thrust(App& app, const Args& a) { app.cmdThrust(u16(a[0])); }
  static void gains(App& app, const Args& a) { app.cmdGains(u16(a[0]), u16(a[1]), u16(a[2])); }
  static void yaw(App& app, const Args& a) { app.cmdYawGains(u16(a[0]), u16(a[1])); }
  static void mode(App& app, const Args& a) {
    app.cmdMode(static_cast<OutputMode>(a[0]), a.has(1) ? static_cast<uint8_t>(a[1]) : 0);
  }
  static void layout(App& app, const Args& a) { app.cmdLayout(static_cast<Layout>(a[0])); }
  static void airframe(App& app, const Args& a) { app.cmdAirframe(u16(a[0]), u16(a[1])); }
  static void hover(App& app, const Args& a) { app.cmdHover(u16(a[0]), u16(a[1])); }
  static void ap(App& app, const Args& a) {
    app.cmdArduPilot(static_cast<int16_t>(a[0]), u16(a[1]), u16(a[2]), u16(a[3]));
  }
  static void apVolts(App& app, const Args& a) { app.cmdArduPilotVolts(u16(a[0]), u16(a[1])); }
  static void apPwm(App& app, const Args& a) { app.cmdArduPilotPwm(u16(a[0]), u16(a[1])); }
  static void crash(App& app, const Args& a) { app.cmdCrash(static_cast<uint8_t>(a[0])); }
  static void calibrate(App& app, const Args&) { app.cmdCalibrate(); }
  static void level(App& app, const Args&) { app.cmdLevel(); }
  static void stream(App& app, const Args& a) { app.cmdStream(a[0] == 0); }  // on|off
  static void status(App& app, const Args&) { app.cmdStatus(); }
  static void strict(App& app, const Args& a) { app.cmdStrict(a[0] == 0); }  // on|off
  static void paramList(App& app, const Args&) { Params::list(app); }
  static void paramAction(App& app, const Args& a) {  // save|load|defaults
    if (a[0] == 0) Params::save(app);
    else if (a[0] == 1) Params::reload(app);
    else Params::defaults(app);
  }
  static void paramGet(App& app, const Args& a) { Params::get(app, a.text[1]); }
  static void paramSet(App& app, const Args& a) { Params::set(app, a.text[1], a.text[2]); }
  static void eeprom(App& app, const Args& a) {  // crc|dump: reading only, the frames go on
    if (app.refuseWhileArmed()) return;
    if (a[0] == 0) fw::eepromCrc();
    else fw::eepromDump(&FlyApp::serviceHook);
  }
  static void rc(App& app, const Args& a) {  // off|ppm|pwm [N]
    app.cmdRc(static_cast<RcProtocol>(a[0]), a.has(1) ? static_cast<uint8_t>(a[1]) : app.rcSettings().pwm_channels);
  }
  static void rcmap(App& app, const Args& a) { app.cmdRcMap(static_cast<uint8_t>(a[0])); }
  static void rates(App& app, const Args& a) {
    app.cmdRates(static_cast<uint8_t>(a[0]), u16(a[1]), u16(a[2]));
  }
  static void fmode(App& app, const Args& a) { app.cmdFlightMode(static_cast<FlightMode>(a[0])); }
  static void dyn(App& app, const Args& a) { app.cmdDyn(a); }
};

// `dyn`: the force API's shaping (force and generic modes; pwm and ardupilot fly pulses).
void FlyApp::cmdDyn(const fw::ArgValues& args) {
  if (refuseWhileArmed()) return;
  fw::dynCommand(motors_, args);
}

bool FlyApp::refuseWhileArmed() const {
  if (!flight_.armed) return false;
  sayLine(TC_FLASH_TEXT("error: armed; send disarm first"));
  return true;
}

ArmRefusal FlyApp::arm(ArmSource source) {
  const ArmRefusal why = armRefusal(armInputs());
  if (why != ArmRefusal::kNone) return why;
  const uint32_t now_ms = hal::Clock::millis();
  controller_.reset();
  restartLoopStats();
  flight_.armed = true;
  flight_.source = source;
  flight_.armed_ms = now_ms;
  flight_.mix_limits = 0;
  flown_since_arm_ = false;
  link_.heard(now_ms);
  if (source == ArmSource::kSticks) {
    flyTheSticks();
  } else {
    updateOutputLimits();
  }
  return ArmRefusal::kNone;
}

// The reply (~1 ms of formatting and printing) waits for the first flown frame (printNotes): said
// at once, it ran across that frame's read whenever the line came late in consoleMayStart's
// window, and held the frame's computation up by as much (thrustcal bench fly: 160-280 us).
void FlyApp::cmdArm() {
  const ArmRefusal why = arm(ArmSource::kConsole);
  if (why != ArmRefusal::kNone) {
    view::armRefused(why, *this);
    return;
  }
  notes_ |= kNoteArmed;
  hold_prompt_ = true;  // printNotes prompts after the reply
}

// While the sticks fly, the setpoint and the thrust are theirs.
bool FlyApp::refuseWhileSticksFly() const {
  if (!flight_.armed || flight_.source != ArmSource::kSticks) return false;
  sayLine(TC_FLASH_TEXT("error: the sticks fly (armed from the receiver); disarm first"));
  return true;
}

void FlyApp::cmdDisarm() {
  if (!flight_.armed) {
    output_.stop();  // stopped already; say so and make sure of it
    sayLine(TC_FLASH_TEXT("disarmed (it was): every ESC at the stop pulse"));
    return;
  }
  disarm(DisarmCause::kCommand);
  notes_ &= static_cast<uint8_t>(~kNoteDisarmed);
  view::disarmed(*this);
}

void FlyApp::cmdSetpoint(int8_t roll_deg, int8_t pitch_deg) {
  if (refuseWhileSticksFly()) return;
  Setpoint& sp = command_.setpoint;
  sp.roll_rad = roll_deg * kRadPerDeg;
  sp.pitch_rad = pitch_deg * kRadPerDeg;
  command_.setpoint_q = fixedSetpoint(sp);
  view::setpoint(*this);
}

void FlyApp::cmdThrust(uint16_t thrust_g) {
  if (refuseWhileSticksFly()) return;
  settings_.thrust_g = thrust_g;
  if (flight_.armed) updateOutputLimits();
  view::thrust(*this);
}

// Gains change disarmed only: armed, a new gain steps the torque by its change times the present
// error (the saved parameters' rule, params.hpp).
void FlyApp::cmdGains(uint16_t kp, uint16_t ki, uint16_t kd) {
  if (refuseWhileArmed()) return;
  ControllerSettings s = controller_.settings();
  s.angle.kp_nm_per_rad = kp * 0.001f;
  s.angle.ki_nm_per_rad_s = ki * 0.001f;
  s.angle.kd_nm_s_per_rad = kd * 0.001f;
  controller_.setSettings(s);
  view::gains(*this);
}

void FlyApp::cmdYawGains(uint16_t kp, uint16_t ki) {
  if (refuseWhileArmed()) return;
  ControllerSettings s = controller_.settings();
  s.yaw.kp_nm_s_per_rad = kp * 0.001f;
  s.yaw.ki_nm_per_rad = ki * 0.001f;
  controller_.setSettings(s);
  view::gains(*this);
}

void FlyApp::cmdMode(OutputMode mode, uint8_t generic_slot) {
  if (refuseWhileArmed()) return;
  if (!output_.setMode(mode, generic_slot)) {
    view::genericSlotRefused(generic_slot, motors_.motor(generic_slot));
    return;
  }
  schedule();
  view::mode(*this);
}

void FlyApp::cmdLayout(Layout layout) {
  if (refuseWhileArmed()) return;
  MixerSettings s = mixer_.settings();
  s.layout = layout;
  configureMixer(s);
  schedule();
  view::layout(*this);
}

void FlyApp::cmdAirframe(uint16_t arm_mm, uint16_t yaw_arm_um) {
  if (refuseWhileArmed()) return;
  MixerSettings s = mixer_.settings();
  s.arm_m = arm_mm * 0.001f;
  s.yaw_arm_m = yaw_arm_um * 0.000001f;
  configureMixer(s);
  view::layout(*this);
}

void FlyApp::cmdHover(uint16_t hover_us, uint16_t slope_mg_per_us) {
  if (refuseWhileArmed()) return;
  PwmModeParams p;
  p.hover_us = hover_us;
  p.slope_g_per_us = slope_mg_per_us * 0.001f;
  output_.setPwmParams(p);
  view::hover(*this);
}

void FlyApp::cmdArduPilot(int16_t expo_e4, uint16_t spin_min_e4, uint16_t spin_max_e4, uint16_t full_g) {
  if (refuseWhileArmed()) return;
  ArduPilotParams p = output_.arduPilot().params();
  p.expo = expo_e4 * 0.0001f;
  p.spin_min = spin_min_e4 * 0.0001f;
  p.spin_max = spin_max_e4 * 0.0001f;
  p.full_thrust_g = full_g;
  output_.setArduPilotParams(p);
  view::arduPilot(*this);
}

void FlyApp::cmdArduPilotVolts(uint16_t max_mv, uint16_t min_mv) {
  if (refuseWhileArmed()) return;
  if (max_mv != 0 && min_mv >= max_mv) {
    sayLine(TC_FLASH_TEXT("error: VMIN_MV must be below VMAX_MV (or VMAX_MV 0: no voltage scaling)"));
    return;
  }
  ArduPilotParams p = output_.arduPilot().params();
  p.bat_volt_max_v = max_mv * 0.001f;
  p.bat_volt_min_v = min_mv * 0.001f;
  output_.setArduPilotParams(p);
  view::arduPilot(*this);
}

void FlyApp::cmdArduPilotPwm(uint16_t min_us, uint16_t max_us) {
  if (refuseWhileArmed()) return;
  if (min_us >= max_us) {
    sayLine(TC_FLASH_TEXT("error: MIN_US must be below MAX_US"));
    return;
  }
  ArduPilotParams p = output_.arduPilot().params();
  p.pwm_min_us = min_us;
  p.pwm_max_us = max_us;
  output_.setArduPilotParams(p);
  view::arduPilot(*this);
}

void FlyApp::cmdCrash(uint8_t deg) {
  settings_.crash_deg = deg;
  command_.crash_units = angleUnitsOfDegrees(deg);
  view::crashLimit(*this);
}

void FlyApp::cmdCalibrate() {
  if (refuseWhileArmed()) return;
  gyro_cal_.restart();
  estimator_.stop();
  view::calibrating();
}

// A calibration whose mean accelerometer becomes the level trim when it ends (frame()).
void FlyApp::cmdLevel() {
  if (refuseWhileArmed()) return;
  level_pending_ = true;
  cmdCalibrate();
}

void FlyApp::cmdStream(bool on) {
  if (on) {
    view::streamHeader();
    streaming_ = true;
    hold_prompt_ = true;  // rows follow
  } else {
    streaming_ = false;
    sayLine(TC_FLASH_TEXT("# stream off"));
  }
}

// The loop's figures as they stand when `status` is asked (its own printing runs frames too).
void FlyApp::cmdStatus() {
  const LoopStats asked = stats_;
  view::status(*this, asked, &FlyApp::serviceHook);
}

void FlyApp::cmdStrict(bool on) { line_.strictCommand(on); }

namespace {

// Argument specs: names as `help` and the errors show them, ranges from the named limits.
const char kRollDeg[] TC_FLASH = "ROLL_DEG";
const char kPitchDeg[] TC_FLASH = "PITCH_DEG";
const char kThrustG[] TC_FLASH = "G";
const char kKp[] TC_FLASH = "KP";
const char kKi[] TC_FLASH = "KI";
const char kKd[] TC_FLASH = "KD";
const char kSlot[] TC_FLASH = "N";
const char kArmMm[] TC_FLASH = "ARM_MM";
const char kYawArmUm[] TC_FLASH = "YAW_ARM_UM";
const char kHoverUs[] TC_FLASH = "US";
const char kSlope[] TC_FLASH = "MG_PER_US";
const char kExpo[] TC_FLASH = "EXPO_E4";
const char kSpinMin[] TC_FLASH = "SPIN_MIN_E4";
const char kSpinMax[] TC_FLASH = "SPIN_MAX_E4";
const char kFullG[] TC_FLASH = "FULL_G";
const char kVmax[] TC_FLASH = "VMAX_MV";
const char kVmin[] TC_FLASH = "VMIN_MV";
const char kMinUs[] TC_FLASH = "MIN_US";
const char kMaxUs[] TC_FLASH = "MAX_US";
const char kDeg[] TC_FLASH = "DEG";
const char kOnOff[] TC_FLASH = "on|off";
const char kParamList[] TC_FLASH = "list";
const char kParamActions[] TC_FLASH = "save|load|defaults";
const char kParamGetWord[] TC_FLASH = "get";
const char kParamSetWord[] TC_FLASH = "set";
const char kParamNameArg[] TC_FLASH = "NAME";
const char kParamValueArg[] TC_FLASH = "VALUE";
const char kCrcDump[] TC_FLASH = "crc|dump";
const char kRcChannels[] TC_FLASH = "N";
const char kAngleDeg[] TC_FLASH = "ANGLE_DEG";
const char kRateDps[] TC_FLASH = "RATE_DPS";
const char kYawDps[] TC_FLASH = "YAW_DPS";

const fw::ArgSpec kSetpointArgs[] TC_FLASH = {{kRollDeg, nullptr, -kMaxSetpointDeg, kMaxSetpointDeg},
                                              {kPitchDeg, nullptr, -kMaxSetpointDeg, kMaxSetpointDeg}};
const fw::ArgSpec kThrustArgs[] TC_FLASH = {{kThrustG, nullptr, 0, kMaxThrustG}};
const fw::ArgSpec kGainArgs[] TC_FLASH = {
    {kKp, nullptr, 0, kMaxGain}, {kKi, nullptr, 0, kMaxGain}, {kKd, nullptr, 0, kMaxGain}};
const fw::ArgSpec kModeArgs[] TC_FLASH = {{kOutputModeWords, kOutputModeWords, 0, 0}, {kSlot, nullptr, 0, kMotors - 1}};
const fw::ArgSpec kLayoutArgs[] TC_FLASH = {{kLayoutWords, kLayoutWords, 0, 0}};
const fw::ArgSpec kAirframeArgs[] TC_FLASH = {{kArmMm, nullptr, kMinArmMm, kMaxArmMm},
                                              {kYawArmUm, nullptr, kMinYawArmUm, kMaxYawArmUm}};
const fw::ArgSpec kHoverArgs[] TC_FLASH = {{kHoverUs, nullptr, tc::kThrottleMinUs + 1, tc::kThrottleMaxUs},
                                           {kSlope, nullptr, 1, kMaxSlopeMgPerUs}};
const fw::ArgSpec kApArgs[] TC_FLASH = {{kExpo, nullptr, -kMaxApExpoE4, kMaxApExpoE4},
                                        {kSpinMin, nullptr, 0, kMaxApSpinMinE4},
                                        {kSpinMax, nullptr, kMinApSpinMaxE4, kMaxApSpinMaxE4},
                                        {kFullG, nullptr, 1, kMaxApFullG}};
const fw::ArgSpec kApVoltArgs[] TC_FLASH = {{kVmax, nullptr, 0, kMaxApVoltMv}, {kVmin, nullptr, 0, kMaxApVoltMv}};
const fw::ArgSpec kApPwmArgs[] TC_FLASH = {{kMinUs, nullptr, hal::kPulseClampMinUs, hal::kPulseClampMaxUs},
                                           {kMaxUs, nullptr, hal::kPulseClampMinUs, hal::kPulseClampMaxUs}};
const fw::ArgSpec kCrashArgs[] TC_FLASH = {{kDeg, nullptr, kMinCrashDeg, kMaxCrashDeg}};
const fw::ArgSpec kOnOffArgs[] TC_FLASH = {{kOnOff, kOnOff, 0, 0}};
const fw::ArgSpec kParamListArgs[] TC_FLASH = {{kParamList, kParamList, 0, 0}};
const fw::ArgSpec kParamActionArgs[] TC_FLASH = {{kParamActions, kParamActions, 0, 0}};
const fw::ArgSpec kParamGetArgs[] TC_FLASH = {{kParamGetWord, kParamGetWord, 0, 0},
                                              {kParamNameArg, fw::kArgText, 0, 0}};
const fw::ArgSpec kParamSetArgs[] TC_FLASH = {{kParamSetWord, kParamSetWord, 0, 0},
                                              {kParamNameArg, fw::kArgText, 0, 0},
                                              {kParamValueArg, fw::kArgText, 0, 0}};
const fw::ArgSpec kEepromArgs[] TC_FLASH = {{kCrcDump, kCrcDump, 0, 0}};
const fw::ArgSpec kRcArgs[] TC_FLASH = {{kRcProtocolWords, kRcProtocolWords, 0, 0},
                                        {kRcChannels, nullptr, kRcMinChannels, kRcMaxChannels}};
const fw::ArgSpec kRcMapArgs[] TC_FLASH = {{kRcMapWords, kRcMapWords, 0, 0}};
const fw::ArgSpec kRatesArgs[] TC_FLASH = {{kAngleDeg, nullptr, kMinStickAngleDeg, kMaxStickAngleDeg},
                                           {kRateDps, nullptr, kMinStickRateDps, kMaxStickRateDps},
                                           {kYawDps, nullptr, kMinStickRateDps, kMaxStickRateDps}};
const fw::ArgSpec kFlightModeArgs[] TC_FLASH = {{kFlightModeWords, kFlightModeWords, 0, 0}};

const char kHelpName[] TC_FLASH = "help";
const char kArmName[] TC_FLASH = "arm";
const char kDisarmName[] TC_FLASH = "disarm";
const char kSpName[] TC_FLASH = "sp";
const char kThrustName[] TC_FLASH = "thrust";
const char kGainsName[] TC_FLASH = "gains";
const char kYawName[] TC_FLASH = "yaw";
const char kModeName[] TC_FLASH = "mode";
const char kLayoutName[] TC_FLASH = "layout";
const char kAirframeName[] TC_FLASH = "airframe";
const char kHoverName[] TC_FLASH = "hover";
const char kApName[] TC_FLASH = "ap";
const char kApVoltName[] TC_FLASH = "apvolt";
const char kApPwmName[] TC_FLASH = "appwm";
const char kCrashName[] TC_FLASH = "crash";
const char kCalibrateName[] TC_FLASH = "calibrate";
const char kLevelName[] TC_FLASH = "level";
const char kStreamName[] TC_FLASH = "stream";
const char kStatusName[] TC_FLASH = "status";
const char kStrictName[] TC_FLASH = "strict";
const char kParamName[] TC_FLASH = "param";
const char kEepromName[] TC_FLASH = "eeprom";
const char kRcName[] TC_FLASH = "rc";
const char kRcMapName[] TC_FLASH = "rcmap";
const char kRatesName[] TC_FLASH = "rates";
const char kFmodeName[] TC_FLASH = "fmode";

const char kHelpHelp[] TC_FLASH = "this list";
const char kArmHelp[] TC_FLASH = "start flying: level, still, IMU ready; spools up in 1 s";
const char kDisarmHelp[] TC_FLASH = "every ESC to the stop pulse, now";
const char kSpHelp[] TC_FLASH = "roll and pitch setpoint in degrees";
const char kThrustHelp[] TC_FLASH = "collective force of all motors (not in mode pwm)";
const char kGainsHelp[] TC_FLASH =
    "roll/pitch PID, mN m per rad, rad s, rad/s\n(the thesis's Kp 2.2, Kd 0.4: 800 0 146)";
const char kYawHelp[] TC_FLASH = "yaw rate PI, mN m per rad/s, rad";
const char kModeHelp[] TC_FLASH =
    "forces to pulses: each motor's own record | slot N's\n"
    "record for all | the thesis's PWM around hover |\n"
    "ArduPilot's curve (motors stopped)";
const char kLayoutHelp[] TC_FLASH = "motor positions (seesaw: 0 left, 1 right)";
const char kAirframeHelp[] TC_FLASH = "arm length; propeller torque per thrust (Q/T)";
const char kHoverHelp[] TC_FLASH = "mode pwm: the hover pulse, the force per us there";
const char kApHelp[] TC_FLASH =
    "mode ardupilot: MOT_THST_EXPO, MOT_SPIN_MIN,\n"
    "MOT_SPIN_MAX in 1/10000, the full thrust in g\n"
    "(thrustcal lab export --to ardupilot)";
const char kApVoltHelp[] TC_FLASH = "MOT_BAT_VOLT_MAX, MOT_BAT_VOLT_MIN (0 0: off)";
const char kApPwmHelp[] TC_FLASH = "MOT_PWM_MIN, MOT_PWM_MAX";
const char kCrashHelp[] TC_FLASH = "disarm beyond this roll or pitch";
const char kCalibrateHelp[] TC_FLASH = "measure the gyro bias again (1 s still)";
const char kLevelHelp[] TC_FLASH = "the vehicle stands level: trim the accelerometer (1 s still)";
const char kStreamHelp[] TC_FLASH =
    "CSV t_s,roll,pitch,roll_sp,pitch_sp (deg),p,q,r (deg/s),\nforce0..3 (g),pulse0..3 (us), 50 lines/s";
const char kStatusHelp[] TC_FLASH = "state, IMU, attitude, settings, loop timing, motors";
const char kStrictHelp[] TC_FLASH = "arm, sp, thrust, gains, yaw, param set|save|load|defaults need a checksum";
const char kRcHelp[] TC_FLASH =
    "receiver: PPM sum on A8 | one pulse per channel on\n"
    "A8.. (N channels, default 5); sticks arm: throttle low,\n"
    "yaw right 1 s; disarm: yaw left";
const char kRcMapHelp[] TC_FLASH = "the first four channels' order (A roll, E pitch, T, R yaw)";
const char kRatesHelp[] TC_FLASH = "full stick: angle (angle mode), roll/pitch rate, yaw rate";
const char kFmodeHelp[] TC_FLASH = "sticks' mode without a switch on channel 5";
// One help row for the five `param` commands and none for `eeprom` (thrustcal board's, docs/fly.md):
// help is one blocking reply, and armed, a longer one drops the keep-alive lines sent while it
// prints (the 64-byte receive ring fills) until the link failsafe disarms (thrustcal bench fly).
const char kParamListHelp[] TC_FLASH =
    "every saved parameter: NAME VALUE  # unit, range; also\nparam get NAME | set NAME VALUE | save|load|defaults";
const char kHiddenHelp[] TC_FLASH = "";  // rows help does not list

// Every console command. kCmdGuarded: what strict mode refuses without a checksum, everything
// that can start the motors or change what armed motors do.
const fw::Command<FlyApp> kCommands[] TC_FLASH = {
    {{kHelpName, nullptr, 0, 0, 0, kHelpHelp}, &Commands::help},
    {{kArmName, nullptr, 0, 0, fw::kCmdGuarded, kArmHelp}, &Commands::arm},
    {{kDisarmName, nullptr, 0, 0, 0, kDisarmHelp}, &Commands::disarm},
    {{kSpName, kSetpointArgs, 2, 2, fw::kCmdGuarded, kSpHelp}, &Commands::setpoint},
    {{kThrustName, kThrustArgs, 1, 1, fw::kCmdGuarded, kThrustHelp}, &Commands::thrust},
    {{kGainsName, kGainArgs, 3, 3, fw::kCmdGuarded, kGainsHelp}, &Commands::gains},
    {{kYawName, kGainArgs, 2, 2, fw::kCmdGuarded, kYawHelp}, &Commands::yaw},
    {{kModeName, kModeArgs, 1, 2, 0, kModeHelp}, &Commands::mode},
    {{kLayoutName, kLayoutArgs, 1, 1, 0, kLayoutHelp}, &Commands::layout},
    {{kAirframeName, kAirframeArgs, 2, 2, 0, kAirframeHelp}, &Commands::airframe},
    {{kHoverName, kHoverArgs, 2, 2, 0, kHoverHelp}, &Commands::hover},
    {{kApName, kApArgs, 4, 4, 0, kApHelp}, &Commands::ap},
    {{kApVoltName, kApVoltArgs, 2, 2, 0, kApVoltHelp}, &Commands::apVolts},
    {{kApPwmName, kApPwmArgs, 2, 2, 0, kApPwmHelp}, &Commands::apPwm},
    {{kCrashName, kCrashArgs, 1, 1, 0, kCrashHelp}, &Commands::crash},
    {{kCalibrateName, nullptr, 0, 0, 0, kCalibrateHelp}, &Commands::calibrate},
    {{kLevelName, nullptr, 0, 0, 0, kLevelHelp}, &Commands::level},
    {{kParamName, kParamListArgs, 1, 1, 0, kParamListHelp}, &Commands::paramList},
    {{kParamName, kParamActionArgs, 1, 1, fw::kCmdGuarded | fw::kCmdHidden, kHiddenHelp}, &Commands::paramAction},
    {{kParamName, kParamGetArgs, 2, 2, fw::kCmdHidden, kHiddenHelp}, &Commands::paramGet},
    {{kParamName, kParamSetArgs, 3, 3, fw::kCmdGuarded | fw::kCmdHidden, kHiddenHelp}, &Commands::paramSet},
    {{kStreamName, kOnOffArgs, 1, 1, 0, kStreamHelp}, &Commands::stream},
    {{kStatusName, nullptr, 0, 0, 0, kStatusHelp}, &Commands::status},
    {{kEepromName, kEepromArgs, 1, 1, fw::kCmdHidden, kHiddenHelp}, &Commands::eeprom},
    {{kStrictName, kOnOffArgs, 1, 1, 0, kStrictHelp}, &Commands::strict},
    {{kRcName, kRcArgs, 1, 2, 0, kRcHelp}, &Commands::rc},
    {{kRcMapName, kRcMapArgs, 1, 1, 0, kRcMapHelp}, &Commands::rcmap},
    {{kRatesName, kRatesArgs, 3, 3, 0, kRatesHelp}, &Commands::rates},
    {{kFmodeName, kFlightModeArgs, 1, 1, 0, kFmodeHelp}, &Commands::fmode},
    // Hidden like eeprom: armed, a longer help drops keep-alive lines (above); docs/fly.md has it.
    {{fw::kDynName, fw::kDynArgs, fw::kDynMinArgs, fw::kDynMaxArgs, fw::kCmdHidden, kHiddenHelp}, &Commands::dyn},
};

}  // namespace

void FlyApp::printHelp() {
  fw::printHelp(kCommands);
  view::helpFooter();
}

// One complete, intact line (the keep-alive is already counted): the row it names runs, or one
// error line says why not. An empty line is a keep-alive only: no reply, no prompt.
void FlyApp::handleLine(char* line) {
  fw::LineContext context;
  context.checksummed = line_.checked();
  context.strict = line_.strict();
  hold_prompt_ = false;
  if (fw::dispatch(*this, kCommands, line, context) == fw::ShellResult::kEmpty) return;
  if (!hold_prompt_ && !streaming_) prompt();
}

}  // namespace fly

// fly's parameter table (params.hpp): one row per saved setting, in flash. The defaults and
// ranges come from the constants the settings already have (controller.hpp, mixer.hpp,
// ardupilot_curve.hpp, fly_rules.hpp, estimator.hpp, rc_input.hpp), so they have one home;
// docs/fly.md's parameter table is generated from these rows (`thrustcal board params table`).
#include "ardupilot_curve.hpp"
#include "controller.hpp"
#include "estimator.hpp"
#include "fly_rules.hpp"
#include "hal/board.hpp"
#include "mixer.hpp"
#include "params.hpp"
#include "rc_input.hpp"
#include "thrustcal/record_limits.hpp"

namespace fly {

namespace {

constexpr int32_t scaled(float x, float scale) {
  return static_cast<int32_t>(x * scale + (x < 0 ? -0.5f : 0.5f));
}
constexpr ArduPilotParams kApDefault = {};
constexpr MixerSettings kMixerDefault = {};
constexpr RcSettings kRcDefault = {};
constexpr StickSettings kStickDefault = {};
// rc_map's default is the first of kRcMapWords, and the mode channel is a channel.
static_assert(kRcDefault.map[0] == 'A' && kRcDefault.map[1] == 'E' && kRcDefault.map[2] == 'T' &&
                  kRcDefault.map[3] == 'R',
              "RcSettings' default map is AETR, the first word of kRcMapWords");
static_assert(kRcDefault.mode_channel < kRcMaxChannels, "a default mode channel the table can hold");
// The level trim in 0.1 mg: the estimator's limit in LSB, rounded.
constexpr int32_t kLevelMaxDmg = scaled(AttitudeEstimator::kMaxLevelTrimLsb, 10000.0f / kAccelLsbPerG);

const char kAngleKp[] TC_FLASH = "angle_kp";
const char kAngleKi[] TC_FLASH = "angle_ki";
const char kAngleKd[] TC_FLASH = "angle_kd";
const char kRateKp[] TC_FLASH = "rate_kp";
const char kRateKi[] TC_FLASH = "rate_ki";
const char kYawKp[] TC_FLASH = "yaw_kp";
const char kYawKi[] TC_FLASH = "yaw_ki";
const char kCrash[] TC_FLASH = "crash_deg";
const char kLayoutName[] TC_FLASH = "layout";
const char kArm[] TC_FLASH = "arm_mm";
const char kYawArm[] TC_FLASH = "yaw_arm_um";
const char kModeName[] TC_FLASH = "mode";
const char kGeneric[] TC_FLASH = "generic_slot";
const char kHover[] TC_FLASH = "hover_us";
const char kSlope[] TC_FLASH = "hover_mg_per_us";
const char kExpo[] TC_FLASH = "ap_expo";
const char kSpinMin[] TC_FLASH = "ap_spin_min";
const char kSpinMax[] TC_FLASH = "ap_spin_max";
const char kFull[] TC_FLASH = "ap_full_g";
const char kVoltMin[] TC_FLASH = "ap_volt_min_mv";
const char kVoltMax[] TC_FLASH = "ap_volt_max_mv";
const char kPwmMin[] TC_FLASH = "ap_pwm_min_us";
const char kPwmMax[] TC_FLASH = "ap_pwm_max_us";
const char kLevelX[] TC_FLASH = "level_x_mg";
const char kLevelY[] TC_FLASH = "level_y_mg";
const char kLevelZ[] TC_FLASH = "level_z_mg";
const char kRcProtocol[] TC_FLASH = "rc_protocol";
const char kRcChannels[] TC_FLASH = "rc_channels";
const char kRcMap[] TC_FLASH = "rc_map";
const char kRcModeChannel[] TC_FLASH = "rc_mode_channel";
const char kFlightMode[] TC_FLASH = "flight_mode";
const char kStickAngle[] TC_FLASH = "stick_angle_deg";
const char kStickRate[] TC_FLASH = "stick_rate_dps";
const char kStickYaw[] TC_FLASH = "stick_yaw_dps";

const char kNoUnit[] TC_FLASH = "";
const char kNmPerRad[] TC_FLASH = "mN m/rad";
const char kNmPerRadS[] TC_FLASH = "mN m/(rad s)";
const char kNmSPerRad[] TC_FLASH = "mN m s/rad";
const char kDeg[] TC_FLASH = "deg";
const char kMm[] TC_FLASH = "mm";
const char kUm[] TC_FLASH = "um";
const char kUs[] TC_FLASH = "us";
const char kMgPerUs[] TC_FLASH = "mg/us";
const char kG[] TC_FLASH = "g";
const char kMv[] TC_FLASH = "mV";
const char kMg[] TC_FLASH = "mg";
const char kDps[] TC_FLASH = "deg/s";


const char kAngleKpHelp[] TC_FLASH =
    "angle mode, roll and pitch: torque per rad of attitude error (the thesis's Kp 2.2: 800)";
const char kAngleKiHelp[] TC_FLASH =
    "angle mode, roll and pitch: torque per rad s of integrated error (0: none, as the thesis)";
const char kAngleKdHelp[] TC_FLASH =
    "angle mode, roll and pitch: torque per rad/s of body rate (the thesis's Kd 0.4: 146)";
const char kRateKpHelp[] TC_FLASH = "rate mode, roll and pitch: torque per rad/s of rate error";
const char kRateKiHelp[] TC_FLASH = "rate mode, roll and pitch: torque per rad of integrated rate error";
const char kYawKpHelp[] TC_FLASH = "yaw, both modes: torque per rad/s of yaw-rate error";
const char kYawKiHelp[] TC_FLASH = "yaw, both modes: torque per rad of integrated yaw-rate error";
const char kCrashHelp[] TC_FLASH = "disarm beyond this roll or pitch (the one row that changes while armed)";
const char kLayoutHelp[] TC_FLASH = "motor positions (seesaw: motor 0 left, 1 right, 2 and 3 stopped)";
const char kArmHelp[] TC_FLASH = "centre to each motor";
const char kYawArmHelp[] TC_FLASH = "propeller torque per thrust, Q/T (an APC 9x4.7 SF: 14900)";
const char kModeHelp[] TC_FLASH =
    "forces to pulses: own records, slot generic_slot's record, the thesis's PWM line, ArduPilot's curve";
const char kGenericHelp[] TC_FLASH = "mode generic: the slot whose record every motor flies";
const char kHoverHelp[] TC_FLASH = "mode pwm: the hover pulse (0: not given, pwm refuses to arm)";
const char kSlopeHelp[] TC_FLASH = "mode pwm: the force per microsecond at hover (0: not given)";
const char kExpoHelp[] TC_FLASH = "mode ardupilot: MOT_THST_EXPO";
const char kSpinMinHelp[] TC_FLASH = "mode ardupilot: MOT_SPIN_MIN";
const char kSpinMaxHelp[] TC_FLASH = "mode ardupilot: MOT_SPIN_MAX";
const char kFullHelp[] TC_FLASH =
    "mode ardupilot: one motor's force at full throttle on a full pack (0: not given, no arming)";
const char kVoltMinHelp[] TC_FLASH = "mode ardupilot: MOT_BAT_VOLT_MIN, below ap_volt_max_mv unless that is 0";
const char kVoltMaxHelp[] TC_FLASH = "mode ardupilot: MOT_BAT_VOLT_MAX (0: no voltage scaling)";
const char kPwmMinHelp[] TC_FLASH = "mode ardupilot: MOT_PWM_MIN, below ap_pwm_max_us";
const char kPwmMaxHelp[] TC_FLASH = "mode ardupilot: MOT_PWM_MAX";
const char kLevelXHelp[] TC_FLASH = "accelerometer trim on x, taken off every tilt it gives (level measures it)";
const char kLevelYHelp[] TC_FLASH = "accelerometer trim on y (level measures it)";
const char kLevelZHelp[] TC_FLASH = "accelerometer trim on z, less 1 g (level measures it)";
const char kRcProtocolHelp[] TC_FLASH = "receiver: none, PPM sum on A8, one pulse per channel from A8";
const char kRcChannelsHelp[] TC_FLASH = "rc_protocol pwm: the channels wired, from A8";
const char kRcMapHelp[] TC_FLASH = "the first four channels' order (A roll, E pitch, T throttle, R yaw)";
const char kRcModeChannelHelp[] TC_FLASH =
    "the channel whose switch flies angle mode (low) or rate mode (high); 0: none";
const char kFlightModeHelp[] TC_FLASH = "the sticks' mode when no mode switch is in the frame";
const char kStickAngleHelp[] TC_FLASH = "angle mode: the roll or pitch a full stick asks for";
const char kStickRateHelp[] TC_FLASH = "rate mode: the roll or pitch rate a full stick asks for";
const char kStickYawHelp[] TC_FLASH = "the yaw rate a full stick asks for, both modes";

}  // namespace

// The word lists (params.hpp), each in its enum's order.
const char kLayoutWords[] TC_FLASH = "plus|x|seesaw";
const char kOutputModeWords[] TC_FLASH = "force|generic|pwm|ardupilot";
const char kRcProtocolWords[] TC_FLASH = "off|ppm|pwm";
const char kRcMapWords[] TC_FLASH = "AETR|TAER|AERT|EATR|ERTA";
const char kFlightModeWords[] TC_FLASH = "angle|rate";

// name, unit, words, help, min, max, default, bytes, decimals, flags, group
const tc::ParamDef kParamRows[kParamCount] TC_FLASH = {
    {kAngleKp, kNmPerRad, nullptr, kAngleKpHelp, 0, kMaxGain, scaled(kThesisGains.kp_nm_per_rad, 1000), 2, 0, 0,
     kGroupGains},
    {kAngleKi, kNmPerRadS, nullptr, kAngleKiHelp, 0, kMaxGain, scaled(kThesisGains.ki_nm_per_rad_s, 1000), 2, 0, 0,
     kGroupGains},
    {kAngleKd, kNmSPerRad, nullptr, kAngleKdHelp, 0, kMaxGain, scaled(kThesisGains.kd_nm_s_per_rad, 1000), 2, 0, 0,
     kGroupGains},
    {kRateKp, kNmSPerRad, nullptr, kRateKpHelp, 0, kMaxGain, scaled(kDefaultRateGains.kp_nm_s_per_rad, 1000), 2, 0,
     0, kGroupGains},
    {kRateKi, kNmPerRad, nullptr, kRateKiHelp, 0, kMaxGain, scaled(kDefaultRateGains.ki_nm_per_rad, 1000), 2, 0, 0,
     kGroupGains},
    {kYawKp, kNmSPerRad, nullptr, kYawKpHelp, 0, kMaxGain, scaled(kDefaultYawGains.kp_nm_s_per_rad, 1000), 2, 0, 0,
     kGroupGains},
    {kYawKi, kNmPerRad, nullptr, kYawKiHelp, 0, kMaxGain, scaled(kDefaultYawGains.ki_nm_per_rad, 1000), 2, 0, 0,
     kGroupGains},
    {kCrash, kDeg, nullptr, kCrashHelp, kMinCrashDeg, kMaxCrashDeg, kDefaultCrashDeg, 1, 0, tc::kParamLive,
     kGroupCrash},
    {kLayoutName, kNoUnit, kLayoutWords, kLayoutHelp, 0, 2, static_cast<int32_t>(kMixerDefault.layout), 1, 0, 0,
     kGroupMixer},
    {kArm, kMm, nullptr, kArmHelp, kMinArmMm, kMaxArmMm, scaled(kDefaultArmM, 1000), 2, 0, 0, kGroupMixer},
    {kYawArm, kUm, nullptr, kYawArmHelp, kMinYawArmUm, kMaxYawArmUm, scaled(kDefaultYawArmM, 1000000), 4, 0, 0,
     kGroupMixer},
    {kModeName, kNoUnit, kOutputModeWords, kModeHelp, 0, 3, static_cast<int32_t>(OutputMode::kForce), 1, 0, 0,
     kGroupMode},
    {kGeneric, kNoUnit, nullptr, kGenericHelp, 0, kMotors - 1, 0, 1, 0, 0, kGroupMode},
    {kHover, kUs, nullptr, kHoverHelp, tc::kThrottleMinUs + 1, tc::kThrottleMaxUs, 0, 2, 0, tc::kParamZeroIsOff,
     kGroupPwm},
    {kSlope, kMgPerUs, nullptr, kSlopeHelp, 1, kMaxSlopeMgPerUs, 0, 2, 0, tc::kParamZeroIsOff, kGroupPwm},
    {kExpo, kNoUnit, nullptr, kExpoHelp, -kMaxApExpoE4, kMaxApExpoE4, scaled(kApDefault.expo, 10000), 2, 4, 0,
     kGroupArduPilot},
    {kSpinMin, kNoUnit, nullptr, kSpinMinHelp, 0, kMaxApSpinMinE4, scaled(kApDefault.spin_min, 10000), 2, 4, 0,
     kGroupArduPilot},
    {kSpinMax, kNoUnit, nullptr, kSpinMaxHelp, kMinApSpinMaxE4, kMaxApSpinMaxE4, scaled(kApDefault.spin_max, 10000),
     2, 4, 0, kGroupArduPilot},
    {kFull, kG, nullptr, kFullHelp, 1, kMaxApFullG, scaled(kApDefault.full_thrust_g, 1), 2, 0, tc::kParamZeroIsOff,
     kGroupArduPilot},
    {kVoltMin, kMv, nullptr, kVoltMinHelp, 0, kMaxApVoltMv, scaled(kApDefault.bat_volt_min_v, 1000), 2, 0,
     tc::kParamBelowNext, kGroupArduPilot},
    {kVoltMax, kMv, nullptr, kVoltMaxHelp, 0, kMaxApVoltMv, scaled(kApDefault.bat_volt_max_v, 1000), 2, 0, 0,
     kGroupArduPilot},
    {kPwmMin, kUs, nullptr, kPwmMinHelp, hal::kPulseClampMinUs, hal::kPulseClampMaxUs, kApDefault.pwm_min_us, 2, 0,
     tc::kParamBelowNext, kGroupArduPilot},
    {kPwmMax, kUs, nullptr, kPwmMaxHelp, hal::kPulseClampMinUs, hal::kPulseClampMaxUs, kApDefault.pwm_max_us, 2, 0,
     0, kGroupArduPilot},
    {kLevelX, kMg, nullptr, kLevelXHelp, -kLevelMaxDmg, kLevelMaxDmg, 0, 2, 1, 0, kGroupLevel},
    {kLevelY, kMg, nullptr, kLevelYHelp, -kLevelMaxDmg, kLevelMaxDmg, 0, 2, 1, 0, kGroupLevel},
    {kLevelZ, kMg, nullptr, kLevelZHelp, -kLevelMaxDmg, kLevelMaxDmg, 0, 2, 1, 0, kGroupLevel},
    {kRcProtocol, kNoUnit, kRcProtocolWords, kRcProtocolHelp, 0, 2, static_cast<int32_t>(kRcDefault.protocol), 1, 0,
     0, kGroupRc},
    {kRcChannels, kNoUnit, nullptr, kRcChannelsHelp, kRcMinChannels, kRcMaxChannels, kRcDefault.pwm_channels, 1, 0,
     0, kGroupRc},
    {kRcMap, kNoUnit, kRcMapWords, kRcMapHelp, 0, 4, 0, 1, 0, 0, kGroupRc},
    {kRcModeChannel, kNoUnit, nullptr, kRcModeChannelHelp, 1, kRcMaxChannels, kRcDefault.mode_channel + 1, 1, 0,
     tc::kParamZeroIsOff, kGroupRc},
    {kFlightMode, kNoUnit, kFlightModeWords, kFlightModeHelp, 0, 1, static_cast<int32_t>(kRcDefault.default_mode), 1,
     0, 0, kGroupRc},
    {kStickAngle, kDeg, nullptr, kStickAngleHelp, kMinStickAngleDeg, kMaxStickAngleDeg, kStickDefault.max_angle_deg,
     1, 0, 0, kGroupSticks},
    {kStickRate, kDps, nullptr, kStickRateHelp, kMinStickRateDps, kMaxStickRateDps, kStickDefault.max_rate_dps, 2, 0,
     0, kGroupSticks},
    {kStickYaw, kDps, nullptr, kStickYawHelp, kMinStickRateDps, kMaxStickRateDps, kStickDefault.max_yaw_rate_dps, 2,
     0, 0, kGroupSticks},
};

// The header the host tools find the table by in fly.hex; fly reads its rows through it too
// (so the linker keeps it).
const tc::ParamTable kParamTable TC_FLASH = {
    {tc::kParamMagic[0], tc::kParamMagic[1], tc::kParamMagic[2], tc::kParamMagic[3], tc::kParamMagic[4],
     tc::kParamMagic[5], tc::kParamMagic[6], tc::kParamMagic[7]},
    kParamLayout,
    kParamCount,
    sizeof(tc::ParamDef),
    0,
    kParamRows};

}  // namespace fly

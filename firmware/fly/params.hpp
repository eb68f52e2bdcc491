// fly's saved parameters (issue 27): one table (params_table.cpp, in flash) of every setting a
// user tunes once and keeps: the gains of each flight mode, the crash limit, the layout and
// airframe, the output mode and the pwm and ardupilot modes' settings, the accelerometer's level
// trim, the receiver (protocol, channels, map, mode switch, default flight mode) and the sticks'
// rates. From the table:
//   - the console's `param list|get NAME|set NAME VALUE|save|load|defaults` (params.cpp);
//   - the EEPROM record (thrustcal/param_store.hpp: two copies in a host slot, power-fail safe),
//     loaded at start-up; an older layout, a copy that cannot be right, none saved or no room:
//     the defaults, said plainly;
//   - the docs' table and the host's parameter files (`thrustcal board params`), which read
//     the table out of fly.hex (its ParamTable header).
//
// The values live where fly uses them, in each stage's settings struct (ControllerSettings,
// MixerSettings, OutputSettings, LevelTrim, FlightSettings, RcSettings, StickSettings):
// capture() reads them from there, apply() writes a group back through the same calls the
// setting commands make (`gains`, `mode`, `rc`, `rates` ...), so the commands and `param set`
// change the same thing and `param list` shows what flies.
//
// Armed, only rows marked tc::kParamLive change (crash_deg: a lower limit can only disarm);
// every other one could step a torque, a pulse or the attitude estimate and make the motors
// jump, and `param save|load|defaults` are refused too (a save stalls the loop ~3.4 ms per
// EEPROM byte on the chip). Arming with unsaved changes is allowed; `status` says so.
#pragma once
#include <stdint.h>

#include "thrustcal/param_store.hpp"
#include "thrustcal/param_table.hpp"

namespace fly {

class FlyApp;

// The record layout of this table: raise it whenever rows are added, removed, reordered or
// change width (tests/firmware/fly/test_fly_params.cpp pins the rows' fingerprint to it).
constexpr uint8_t kParamLayout = 1;

// Rows in table order (params_table.cpp).
enum ParamId : uint8_t {
  kParamAngleKp,  // angle mode, roll and pitch (ControllerSettings::angle)
  kParamAngleKi,
  kParamAngleKd,
  kParamRateKp,  // rate mode, roll and pitch (ControllerSettings::rate)
  kParamRateKi,
  kParamYawKp,  // yaw, both modes (ControllerSettings::yaw)
  kParamYawKi,
  kParamCrashDeg,  // FlightSettings
  kParamLayoutWord,  // MixerSettings
  kParamArmMm,
  kParamYawArmUm,
  kParamMode,  // OutputSettings
  kParamGenericSlot,
  kParamHoverUs,
  kParamHoverSlope,
  kParamApExpo,
  kParamApSpinMin,
  kParamApSpinMax,
  kParamApFullG,
  kParamApVoltMin,
  kParamApVoltMax,
  kParamApPwmMin,
  kParamApPwmMax,
  kParamLevelX,  // LevelTrim
  kParamLevelY,
  kParamLevelZ,
  kParamRcProtocol,  // RcSettings
  kParamRcChannels,
  kParamRcMap,
  kParamRcModeChannel,
  kParamFlightMode,
  kParamStickAngleDeg,  // StickSettings
  kParamStickRateDps,
  kParamStickYawDps,
  kParamCount
};

// What applying a row touches (ParamDef::group; apply() takes a mask of them).
enum ParamGroup : uint8_t {
  kGroupGains,
  kGroupCrash,
  kGroupMixer,
  kGroupMode,
  kGroupPwm,
  kGroupArduPilot,
  kGroupLevel,
  kGroupRc,
  kGroupSticks,
  kGroupCount
};
constexpr uint16_t kAllGroups = (1u << kGroupCount) - 1u;

// Ranges the table and the setting commands share (commands.cpp's argument specs).
constexpr uint16_t kMaxGain = 10000;  // mN m per rad (or per rad/s, rad s)
constexpr uint16_t kMinArmMm = 50, kMaxArmMm = 1000;
constexpr uint32_t kMinYawArmUm = 1000, kMaxYawArmUm = 100000;
constexpr uint16_t kMaxSlopeMgPerUs = 20000;
constexpr int16_t kMaxApExpoE4 = 10000;
constexpr uint16_t kMaxApSpinMinE4 = 3000, kMinApSpinMaxE4 = 9000, kMaxApSpinMaxE4 = 10000;
constexpr uint16_t kMaxApFullG = 20000;
constexpr uint16_t kMaxApVoltMv = 26000;
constexpr uint8_t kMinStickAngleDeg = 5, kMaxStickAngleDeg = 60;
constexpr uint16_t kMinStickRateDps = 10, kMaxStickRateDps = 1000;

// The words of the settings that are one of a few (the table's rows and the setting commands'
// arguments), each in its enum's order.
extern const char kLayoutWords[] TC_FLASH;      // Layout
extern const char kOutputModeWords[] TC_FLASH;  // OutputMode
extern const char kRcProtocolWords[] TC_FLASH;  // RcProtocol
extern const char kRcMapWords[] TC_FLASH;       // the channel orders `rcmap` offers
extern const char kFlightModeWords[] TC_FLASH;  // FlightMode

extern const tc::ParamDef kParamRows[kParamCount] TC_FLASH;
extern const tc::ParamTable kParamTable TC_FLASH;

using ParamValues = int32_t[kParamCount];

// What the EEPROM gives at start-up (and what a reset would give now).
enum class ParamLoad : uint8_t {
  kLoaded,         // the saved record: flown
  kNone,           // none saved: the defaults
  kNoRoom,         // every slot holds a thesis record: none can be saved, the defaults
  kOtherLayout,    // saved by a fly with another table: the defaults
  kCannotBeRight,  // a value outside its range or a broken rule: the defaults
};
struct SavedState {
  ParamLoad how = ParamLoad::kNone;
  tc::ParamsRead where;
  tc::ParamCheck check;  // kCannotBeRight: the row at fault
  int32_t value[2] = {0, 0};  // kCannotBeRight: its value and the next row's
  uint8_t layout = 0;    // kOtherLayout: the record's
};

// The parameter side of FlyApp (a friend): reads and writes its settings, and the `param`
// commands. How each fails is said on the console; nothing here spins a motor.
struct Params {
  // The values fly flies now.
  static void capture(const FlyApp& app, ParamValues& v);
  // `v`'s rows of the groups in `mask` into fly (v already checked: tc::checkParams). False
  // when the mode cannot be taken (generic: slot N has no valid record): the mode is kept.
  static bool apply(FlyApp& app, const ParamValues& v, uint16_t mask);
  // What a reset would give: the saved record if it can be flown, else the defaults.
  static SavedState onReset(ParamValues& v);
  // The values flying now and on reset; how many differ.
  static uint8_t unsaved(const FlyApp& app, ParamValues& now, ParamValues& reset, SavedState* state = nullptr);
  // Serves the frames (FlyApp's service) between the EEPROM bytes of a save.
  static void serve();

  // Start-up: the saved record, or the defaults; says which and why.
  static void load(FlyApp& app);

  // The console (arguments as typed; fw::kArgText).
  static void list(const FlyApp& app);
  static void get(const FlyApp& app, const char* name);
  static void set(FlyApp& app, const char* name, const char* text);
  static void save(FlyApp& app);
  static void reload(FlyApp& app);
  static void defaults(FlyApp& app);
  // `status`'s line: saved or not, where.
  static void sayStatus(const FlyApp& app);
};

}  // namespace fly

// read_run's console commands: one table in flash (fw::Command rows, firmware/common/shell.hpp),
// a one-call handler per row and the command methods they call. The shell parses and range-checks the arguments from the rows,
// refuses guarded rows without a checksum in strict mode and prints `help` from them; a
// handler runs only with arguments its row accepted. docs/read_run.md holds the help text a
// host test compares with printHelp().
#include "console_view.hpp"
#include "dyn_console.hpp"
#include "eeprom_console.hpp"
#include "read_run_app.hpp"
#include "record_report.hpp"
#include "shell.hpp"
#include "slot_report.hpp"

namespace rr {

// `help` spells these defaults and this pace in flash text; a changed constant must change it.
static_assert(Liftoff::kDefaultRampMs == 2000 && Liftoff::kDefaultHoldMs == 5000,
              "the liftoff help row says default 2000 ms ramp, 5000 ms hold");
static_assert(kStreamLinesPerSecond == 10 && kMotors == 4,
              "the stream help row says motor0..motor3, 10 lines/s");

using fw::sayLine;

// The table's handlers: one call each, from the parsed arguments to the app's command. The
// logic is in the cmd methods below, next to the state they change (the same shape as
// gather_store's GatherStoreCommands).
struct Commands {
  using App = ReadRunApp;
  using Args = fw::ArgValues;
  static uint16_t u16(int32_t v) { return static_cast<uint16_t>(v); }

  static void help(App&, const Args&) { App::printHelp(); }
  static void forceAll(App& app, const Args& a) { app.cmdForceAll(u16(a[0])); }
  static void forceOne(App& app, const Args& a) { app.cmdForceOne(static_cast<uint8_t>(a[0]), u16(a[1])); }
  static void stop(App& app, const Args&) { app.cmdStop(); }
  static void status(App& app, const Args&) { app.cmdStatus(); }
  static void liftoff(App& app, const Args& a) {
    app.cmdLiftoff(u16(a[0]), a.has(1) ? u16(a[1]) : Liftoff::kDefaultRampMs,
                   a.has(2) ? u16(a[2]) : Liftoff::kDefaultHoldMs);
  }
  static void stream(App& app, const Args& a) { app.cmdStream(a[0] == 0); }  // on|off
  static void rate(App& app, const Args& a) { app.cmdRate(u16(a[0])); }
  static void eeprom(App& app, const Args& a) { app.cmdEeprom(a[0] != 0); }  // crc|dump
  static void dividerShow(App& app, const Args&) { app.cmdDividerShow(); }
  static void dividerSet(App& app, const Args& a) {
    app.cmdDivider(static_cast<uint32_t>(a[0]), static_cast<uint32_t>(a[1]));
  }
  static void strict(App& app, const Args& a) { app.cmdStrict(a[0] == 0); }  // on|off
  static void dyn(App& app, const Args& a) { app.cmdDyn(a); }
};

// f G: every calibrated motor; the others stay at 1000 us with a warning.
void ReadRunApp::cmdForceAll(uint16_t force_g) {
  if (motors_.armableCount() == 0) {
    sayLine(TC_FLASH_TEXT("error: no motor is calibrated; calibrate them with gather_store first"));
    return;
  }
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (motors_.isArmable(i)) {
      motors_.setForceDg(i, static_cast<uint16_t>(force_g * 10u));  // G <= tc::kRecordMaxForceG
    } else {
      view::heldMotor(i, motors_.motor(i));
    }
  }
}

void ReadRunApp::cmdForceOne(uint8_t index, uint16_t force_g) {
  if (!requireArmable(index)) return;
  motors_.setForceDg(index, static_cast<uint16_t>(force_g * 10u));
}

void ReadRunApp::cmdStop() {
  stopAll();
  sayLine(TC_FLASH_TEXT("stopped: every ESC at 1000 us"));
}

void ReadRunApp::cmdStatus() { view::status(*this, &ReadRunApp::serviceHook); }

void ReadRunApp::cmdLiftoff(uint16_t force_g, uint16_t ramp_ms, uint16_t hold_ms) {
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (!motors_.isArmable(i)) {
      view::liftoffNeedsAll(i, motors_.motor(i));
      return;
    }
  }
  if (isRunning()) {
    sayLine(TC_FLASH_TEXT("error: motors are running; send stop first, then liftoff"));
    return;
  }
  const uint32_t now_ms = hal::Clock::millis();
  liftoff_.start(force_g, ramp_ms, hold_ms, now_ms);
  link_.heard(now_ms);  // the link timeout counts from the command
  mode_ = Mode::kLiftoff;
  hold_prompt_ = true;  // its progress lines follow; the prompt comes at the end
  view::liftoffStarted(force_g, ramp_ms, hold_ms);
}

void ReadRunApp::cmdStream(bool on) {
  if (on) {
    view::streamHeader();
    stream_.on = true;
    stream_.countdown = 0;
    hold_prompt_ = true;  // the next line is a CSV row, and must start clean
  } else {
    stream_.on = false;
    sayLine(TC_FLASH_TEXT("# stream off"));
  }
}

void ReadRunApp::cmdRate(uint16_t frame_hz) {
  if (isRunning()) {
    sayLine(TC_FLASH_TEXT("error: motors are running; send stop first, then change the rate"));
    return;
  }
  if (!hal::Esc::setFrameRate(frame_hz)) {
    sayLine(TC_FLASH_TEXT("error: the ESC driver refused that rate; nothing changed"));
    return;
  }
  setFrameRate(frame_hz);
  scheduleFrames();  // the phase hook after the new rate (hal::Esc::setPhaseHook)
  fw::say(TC_FLASH_TEXT("frame rate "));
  fw::printUint(frame_hz);
  sayLine(TC_FLASH_TEXT(" Hz"));
}

void ReadRunApp::cmdEeprom(bool dump) {
  if (isRunning()) {
    sayLine(TC_FLASH_TEXT("error: eeprom: motors are running; send stop first"));
  } else if (dump) {
    fw::eepromDump();
  } else {
    fw::eepromCrc();
  }
}

void ReadRunApp::cmdDividerShow() {
  fw::printDivider(motors_.boardSettings());
  fw::newline();
}

// `divider R1 R2`: the battery monitor's divider (thrustcal/board_settings.hpp). A new value is
// stored, then the calibration is loaded again against it: volts come from counts through it,
// and a record's voltages must lie within its full scale.
void ReadRunApp::cmdDivider(uint32_t top_ohm, uint32_t bottom_ohm) {
  if (isRunning()) {
    sayLine(TC_FLASH_TEXT("error: motors are running; send stop first, then set the divider"));
    return;
  }
  if (!fw::setDivider(top_ohm, bottom_ohm, motors_.boardSettings())) return;
  motors_.restartFilters();
  loadCalibration();
}

void ReadRunApp::cmdStrict(bool on) { line_.strictCommand(on); }

void ReadRunApp::cmdDyn(const fw::ArgValues& args) {
  if (isRunning()) {
    sayLine(TC_FLASH_TEXT("error: motors are running; send stop first, then dyn"));
    return;
  }
  fw::dynCommand(motors_, args);
}

namespace {

// Argument specs: names as `help` and the errors show them, ranges from the named limits.
const char kG[] TC_FLASH = "G";
const char kN[] TC_FLASH = "N";
const char kRampMs[] TC_FLASH = "RAMP_MS";
const char kHoldMs[] TC_FLASH = "HOLD_MS";
const char kHz[] TC_FLASH = "HZ";
const char kR1[] TC_FLASH = "R1_OHM";
const char kR2[] TC_FLASH = "R2_OHM";
const char kOnOff[] TC_FLASH = "on|off";
const char kCrcDump[] TC_FLASH = "crc|dump";

constexpr int32_t kDividerMax = static_cast<int32_t>(tc::kDividerMaxOhm);

const fw::ArgSpec kForceAllArgs[] TC_FLASH = {{kG, nullptr, 0, kForceMaxG}};
const fw::ArgSpec kForceOneArgs[] TC_FLASH = {{kN, nullptr, 0, kMotors - 1},
                                                {kG, nullptr, 0, kForceMaxG}};
const fw::ArgSpec kLiftoffArgs[] TC_FLASH = {{kG, nullptr, 1, kForceMaxG},
                                               {kRampMs, nullptr, 0, Liftoff::kMaxMs},
                                               {kHoldMs, nullptr, 0, Liftoff::kMaxMs}};
const fw::ArgSpec kOnOffArgs[] TC_FLASH = {{kOnOff, kOnOff, 0, 0}};
const fw::ArgSpec kRateArgs[] TC_FLASH = {{kHz, nullptr, hal::kEscMinFrameHz, hal::kEscMaxFrameHz}};
const fw::ArgSpec kEepromArgs[] TC_FLASH = {{kCrcDump, kCrcDump, 0, 0}};
const fw::ArgSpec kDividerArgs[] TC_FLASH = {{kR1, nullptr, 0, kDividerMax},
                                               {kR2, nullptr, 0, kDividerMax}};

const char kHelpName[] TC_FLASH = "help";
const char kFName[] TC_FLASH = "f";
const char kStopName[] TC_FLASH = "stop";
const char kStatusName[] TC_FLASH = "status";
const char kLiftoffName[] TC_FLASH = "liftoff";
const char kStreamName[] TC_FLASH = "stream";
const char kRateName[] TC_FLASH = "rate";
const char kEepromName[] TC_FLASH = "eeprom";
const char kDividerName[] TC_FLASH = "divider";
const char kStrictName[] TC_FLASH = "strict";

const char kHelpHelp[] TC_FLASH = "this list";
const char kForceAllHelp[] TC_FLASH = "all calibrated motors to G grams";
const char kForceOneHelp[] TC_FLASH = "motor N to G grams";
const char kStopHelp[] TC_FLASH = "all motors to 0 g (1000 us)";
const char kStatusHelp[] TC_FLASH = "per motor: force, pwm, battery, flags; v2 motors: headroom";
const char kLiftoffHelp[] TC_FLASH =
    "ramp all four 0->G g (default 2000 ms),\nhold (default 5000 ms), stop; empty lines keep it "
    "going,\nany other key aborts";
const char kStreamHelp[] TC_FLASH = "CSV t_s,motor0_pwm_us..motor3_pwm_us,vbat_v, 10 lines/s";
const char kRateHelp[] TC_FLASH = "ESC frames per second (motors stopped)";
const char kEepromHelp[] TC_FLASH = "EEPROM CRC-16 per slot and whole, or Intel HEX (stopped)";
const char kDividerShowHelp[] TC_FLASH = "the battery divider and its full scale";
const char kDividerSetHelp[] TC_FLASH =
    "battery divider in ohm: R1 pack-A1, R2 A1-ground\n(thesis 100000 47000); reloads the "
    "calibration,\nmotors stopped";
const char kStrictHelp[] TC_FLASH = "f (above 0 g), liftoff, divider R1_OHM R2_OHM need a checksum";

// Every console command. kCmdGuarded marks what strict mode refuses without a checksum: what
// can spin a motor (f above 0 g, liftoff) or write the EEPROM (divider R1 R2).
const fw::Command<ReadRunApp> kCommands[] TC_FLASH = {
    {{kHelpName, nullptr, 0, 0, 0, kHelpHelp}, &Commands::help},
    {{kFName, kForceAllArgs, 1, 1, fw::kCmdGuarded | fw::kCmdZeroIsStop, kForceAllHelp},
     &Commands::forceAll},
    {{kFName, kForceOneArgs, 2, 2, fw::kCmdGuarded | fw::kCmdZeroIsStop, kForceOneHelp},
     &Commands::forceOne},
    {{kStopName, nullptr, 0, 0, 0, kStopHelp}, &Commands::stop},
    {{kStatusName, nullptr, 0, 0, 0, kStatusHelp}, &Commands::status},
    {{kLiftoffName, kLiftoffArgs, 1, 3, fw::kCmdGuarded, kLiftoffHelp}, &Commands::liftoff},
    {{kStreamName, kOnOffArgs, 1, 1, 0, kStreamHelp}, &Commands::stream},
    {{kRateName, kRateArgs, 1, 1, 0, kRateHelp}, &Commands::rate},
    {{kEepromName, kEepromArgs, 1, 1, 0, kEepromHelp}, &Commands::eeprom},
    {{kDividerName, nullptr, 0, 0, 0, kDividerShowHelp}, &Commands::dividerShow},
    {{kDividerName, kDividerArgs, 2, 2, fw::kCmdGuarded, kDividerSetHelp}, &Commands::dividerSet},
    {{kStrictName, kOnOffArgs, 1, 1, 0, kStrictHelp}, &Commands::strict},
    {{fw::kDynName, fw::kDynArgs, fw::kDynMinArgs, fw::kDynMaxArgs, 0, fw::kDynHelp}, &Commands::dyn},
};

}  // namespace

void ReadRunApp::printHelp() {
  fw::printHelp(kCommands);
  view::helpFooter();
}

// One complete, intact line (the keep-alive is already counted): the row it names runs, or
// one error line says why not. An empty line is a keep-alive only: no reply, no prompt (hosts
// send it twice a second and more).
void ReadRunApp::handleLine(char* line) {
  fw::LineContext context;
  context.checksummed = line_.checked();
  context.strict = line_.strict();
  hold_prompt_ = false;
  if (fw::dispatch(*this, kCommands, line, context) == fw::ShellResult::kEmpty) return;
  if (!hold_prompt_) prompt();
}

bool ReadRunApp::requireArmable(uint8_t index) const {
  if (motors_.isArmable(index)) return true;
  view::refuseMotor(index, motors_.motor(index));
  return false;
}

}  // namespace rr

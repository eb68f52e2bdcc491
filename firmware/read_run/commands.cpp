// read_run's console commands: one table in flash (fw::Command rows, firmware/common/shell.hpp)
// and a handler per row. The shell parses and range-checks the arguments from the rows,
// refuses guarded rows without a checksum in strict mode and prints `help` from them; a
// handler runs only with arguments its row accepted. docs/read_run.md holds the help text a
// host test compares with printHelp().
#include "console_view.hpp"
#include "eeprom_console.hpp"
#include "read_run_app.hpp"
#include "shell.hpp"

namespace rr {

// `help` spells these defaults and this pace in flash text; a changed constant must change it.
static_assert(kLiftoffDefaultRampMs == 2000 && kLiftoffDefaultHoldMs == 5000,
              "the liftoff help row says default 2000 ms ramp, 5000 ms hold");
static_assert(kStreamLinesPerSecond == 10 && kMotors == 4,
              "the stream help row says motor0..motor3, 10 lines/s");

using fw::sayLine;

struct Commands {
  static void help(ReadRunApp&, const fw::ArgValues&) { ReadRunApp::printHelp(); }

  // f G: every calibrated motor; the others stay at 1000 us with a warning.
  static void forceAll(ReadRunApp& app, const fw::ArgValues& args) {
    uint8_t armable = 0;
    for (uint8_t i = 0; i < kMotors; ++i) armable += app.motors_[i].isArmable() ? 1 : 0;
    if (armable == 0) {
      sayLine(TC_FLASH_TEXT("error: no motor is calibrated; calibrate them with gather_store first"));
      return;
    }
    for (uint8_t i = 0; i < kMotors; ++i) {
      if (app.motors_[i].isArmable()) {
        app.setForce(i, static_cast<uint16_t>(args[0]));
      } else {
        view::heldMotor(i, app.motors_[i]);
      }
    }
  }

  static void forceOne(ReadRunApp& app, const fw::ArgValues& args) {
    const uint8_t index = static_cast<uint8_t>(args[0]);
    if (!app.requireArmable(index)) return;
    app.setForce(index, static_cast<uint16_t>(args[1]));
  }

  static void stop(ReadRunApp& app, const fw::ArgValues&) {
    app.stopAll();
    sayLine(TC_FLASH_TEXT("stopped: every ESC at 1000 us"));
  }

  static void status(ReadRunApp& app, const fw::ArgValues&) {
    view::status(app, &ReadRunApp::serviceHook);
  }

  static void liftoff(ReadRunApp& app, const fw::ArgValues& args) {
    for (uint8_t i = 0; i < kMotors; ++i) {
      if (!app.motors_[i].isArmable()) {
        view::liftoffNeedsAll(i, app.motors_[i]);
        return;
      }
    }
    if (app.isRunning()) {
      sayLine(TC_FLASH_TEXT("error: motors are running; send stop first, then liftoff"));
      return;
    }
    const uint32_t now_ms = hal::Clock::millis();
    app.liftoff_force_g_ = static_cast<uint16_t>(args[0]);
    app.liftoff_ramp_ms_ = args.has(1) ? static_cast<uint16_t>(args[1]) : kLiftoffDefaultRampMs;
    app.liftoff_hold_ms_ = args.has(2) ? static_cast<uint16_t>(args[2]) : kLiftoffDefaultHoldMs;
    app.liftoff_start_ms_ = now_ms;
    app.liftoff_next_progress_ms_ = now_ms;
    app.liftoff_holding_ = false;
    app.last_line_ms_ = now_ms;  // the link timeout counts from the command
    app.mode_ = Mode::kLiftoff;
    app.hold_prompt_ = true;  // its progress lines follow; the prompt comes at the end
    view::liftoffStarted(app.liftoff_force_g_, app.liftoff_ramp_ms_, app.liftoff_hold_ms_);
  }

  static void stream(ReadRunApp& app, const fw::ArgValues& args) {
    if (args[0] == 0) {  // on
      view::streamHeader();
      app.stream_ = true;
      app.stream_countdown_ = 0;
      app.hold_prompt_ = true;  // the next line is a CSV row, and must start clean
    } else {
      app.stream_ = false;
      sayLine(TC_FLASH_TEXT("# stream off"));
    }
  }

  static void rate(ReadRunApp& app, const fw::ArgValues& args) {
    const uint16_t hz = static_cast<uint16_t>(args[0]);
    if (app.isRunning()) {
      sayLine(TC_FLASH_TEXT("error: motors are running; send stop first, then change the rate"));
      return;
    }
    if (!hal::Esc::setFrameRate(hz)) {
      sayLine(TC_FLASH_TEXT("error: the ESC driver refused that rate; nothing changed"));
      return;
    }
    app.setFrameRate(hz);
    app.scheduleFrames(hal::Clock::millis());
    fw::say(TC_FLASH_TEXT("frame rate "));
    fw::printUint(hz);
    sayLine(TC_FLASH_TEXT(" Hz"));
  }

  static void eeprom(ReadRunApp& app, const fw::ArgValues& args) {
    if (app.isRunning()) {
      sayLine(TC_FLASH_TEXT("error: eeprom: motors are running; send stop first"));
    } else if (args[0] == 0) {
      fw::eepromCrc();
    } else {
      fw::eepromDump();
    }
  }

  static void dividerShow(ReadRunApp& app, const fw::ArgValues&) {
    fw::printDivider(app.settings_);
    fw::newline();
  }

  // `divider R1 R2`: the battery monitor's divider (thrustcal/board_settings.hpp). A new value
  // is stored, then the calibration is loaded again against it: volts come from counts through
  // it, and a record's voltages must lie within its full scale.
  static void dividerSet(ReadRunApp& app, const fw::ArgValues& args) {
    if (app.isRunning()) {
      sayLine(TC_FLASH_TEXT("error: motors are running; send stop first, then set the divider"));
      return;
    }
    if (!fw::setDivider(static_cast<uint32_t>(args[0]), static_cast<uint32_t>(args[1]),
                        app.settings_)) {
      return;
    }
    const uint8_t shift = app.v2_.bus.shift;
    app.v2_.bus = tc::BusVoltageFilter();  // its millivolts came through the old divider
    app.v2_.bus.shift = shift;
    app.v2_.sag = tc::BusSagFilter();
    app.bus_sample_sane_ = false;
    app.loadCalibration();
  }

  static void strict(ReadRunApp& app, const fw::ArgValues& args) {
    app.line_.strictCommand(args[0] == 0);
  }
};

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
                                               {kRampMs, nullptr, 0, kLiftoffMaxMs},
                                               {kHoldMs, nullptr, 0, kLiftoffMaxMs}};
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
  const Motor& m = motors_[index];
  if (m.isArmable()) return true;
  view::refuseMotor(index, m);
  return false;
}

}  // namespace rr

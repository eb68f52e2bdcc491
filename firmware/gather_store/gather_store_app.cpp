// Gather and Store console (see gather_store_app.hpp for the flow and the rules).
// Every constant string goes through TC_PSTR so it stays in flash on the AVR.
#include "gather_store_app.hpp"

#include "eeprom_console.hpp"
#include "hal/hal.hpp"
#include "record_report.hpp"
#include "thrustcal/eeprom_store.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/record_v2.hpp"

namespace gs {

namespace {

constexpr uint8_t kMaxTokens = 4;  // command + up to 2 arguments + 1 to detect extras
constexpr int16_t kDecigramsPerGram = 10;

using fw::say;
using fw::sayCopy;
using fw::sayLine;

// Nearest integer of num / den (den > 0), halves away from zero.
int32_t divRound(int32_t num, int32_t den) {
  return num >= 0 ? (num + den / 2) / den : -((-num + den / 2) / den);
}

int32_t absolute(int32_t v) { return v < 0 ? -v : v; }

// hal::Eeprom through the codecs' Storage interface, counting the bytes that change: the
// physical writes (updateByte skips a byte that already holds the value).
struct CountingEeprom {
  static uint16_t written;
  static uint8_t readByte(uint16_t addr) { return hal::Eeprom::readByte(addr); }
  static void updateByte(uint16_t addr, uint8_t value) {
    if (hal::Eeprom::readByte(addr) != value) ++written;
    hal::Eeprom::updateByte(addr, value);
  }
};
uint16_t CountingEeprom::written = 0;

// "; wrote N bytes" + newline
void sayWritten() {
  say(TC_PSTR("; wrote "));
  fw::printUint(CountingEeprom::written);
  sayLine(CountingEeprom::written == 1 ? TC_PSTR(" byte") : TC_PSTR(" bytes"));
}

// 1/16 us -> "1083.4 us"
void printQ4Us(uint16_t q4_us) {
  fw::printFixed(static_cast<int32_t>((static_cast<uint32_t>(q4_us) * 10u + 8u) >> 4), 1);
  say(TC_PSTR(" us"));
}

void printEscPin(uint8_t slot) {
  switch (slot) {
    case 0: say(TC_PSTR("D6 (PH3, OC4A)")); break;
    case 1: say(TC_PSTR("D7 (PH4, OC4B)")); break;
    case 2: say(TC_PSTR("D8 (PH5, OC4C)")); break;
    default: say(TC_PSTR("D11 (PB5, OC1A)")); break;
  }
}

void printRecordRange(uint8_t slot) {
  say(TC_PSTR("EEPROM "));
  fw::printUint(tc::slotAddress(slot));
  say(TC_PSTR(".."));
  fw::printUint(tc::slotAddress(slot) + tc::kRecordBytes - 1u);
}

// "error: <what> must be a whole number in MIN..MAX, got 'TOKEN'; nothing changed"
void rangeError(const char* what_progmem, int32_t min, int32_t max, const char* token) {
  say(TC_PSTR("error: "));
  say(what_progmem);
  say(TC_PSTR(" must be a whole number in "));
  fw::printInt(min);
  say(TC_PSTR(".."));
  fw::printInt(max);
  say(TC_PSTR(", got '"));
  hal::Uart::print(token);
  sayLine(TC_PSTR("'; nothing changed"));
}

// "error: usage: <usage>; nothing changed"
void usageError(const char* usage_progmem) {
  say(TC_PSTR("error: usage: "));
  say(usage_progmem);
  sayLine(TC_PSTR("; nothing changed"));
}

// One argument in [min, max]; prints the error itself.
bool oneArg(char** args, uint8_t n, const char* usage_progmem, const char* what_progmem,
            int32_t min, int32_t max, int32_t& value) {
  if (n != 2) {
    usageError(usage_progmem);
    return false;
  }
  if (!fw::parseInt(args[1], min, max, value)) {
    rangeError(what_progmem, min, max, args[1]);
    return false;
  }
  return true;
}

// Why model v2 could not use a sweep (flash copies of tc::fitV2StatusText's reasons: the core's
// texts are plain strings, which the AVR keeps in SRAM).
void printFitProblem(tc::FitV2Status status) {
  switch (status) {
    case tc::FitV2Status::kOk: say(TC_PSTR("ok")); break;
    case tc::FitV2Status::kTooFewSamples:
      say(TC_PSTR("fewer than 8 PWM steps: widen the range or use a smaller step"));
      break;
    case tc::FitV2Status::kNoForce:
      say(TC_PSTR("the force never reached 5 g: motor not spinning or cell not tared?"));
      break;
    case tc::FitV2Status::kBadVoltage:
      say(TC_PSTR("a battery reading outside 3..26 V: check the monitor wiring on A1 and the "
                  "divider setting"));
      break;
    case tc::FitV2Status::kStartNotFound:
      say(TC_PSTR("ESC start threshold not found: sweep from 1000 us to full force in "
                  "steps of at most 10 us"));
      break;
    case tc::FitV2Status::kVoltagesTooClose:
      say(TC_PSTR("the two sweeps rested within 0.5 V of each other"));
      break;
    case tc::FitV2Status::kNoModel: say(TC_PSTR("no model to refine")); break;
  }
}

void printBuildProblem(tc::BuildStatus status) {
  switch (status) {
    case tc::BuildStatus::kTooFewSamples:
      sayLine(TC_PSTR("fewer than 2 PWM steps: widen the range (range MIN MAX)"));
      break;
    case tc::BuildStatus::kNoForce:
      sayLine(TC_PSTR("the force never reached 1 g: check that the motor spins with its "
                      "propeller and that the cell was tared with the motor stopped"));
      break;
    case tc::BuildStatus::kCurveTooSteep:
      sayLine(TC_PSTR("two neighbouring grams lie more than 254 us apart: use a smaller step"));
      break;
    case tc::BuildStatus::kOk:
      fw::newline();
      break;
  }
}

// "curve 1: start 12.600 V, 1..500 g; 1 g 1105 us, 100 g 1310 us, ..."
void printCurve(uint8_t which, const tc::ForceCurveBase& curve) {
  say(TC_PSTR("curve "));
  fw::printUint(which);
  say(TC_PSTR(": start "));
  fw::sayVolts(curve.start_mv);
  say(TC_PSTR(", 1.."));
  fw::printUint(curve.maxGrams());
  say(TC_PSTR(" g; PWM per gram:"));
  uint16_t grams = 1;
  for (;;) {
    hal::Uart::write(' ');
    fw::printUint(grams);
    say(TC_PSTR(" g "));
    fw::printUint(curve.pwmForGrams(grams));
    say(TC_PSTR(" us"));
    if (grams == curve.maxGrams()) break;
    grams = grams == 1 ? 100 : static_cast<uint16_t>(grams + 100);
    if (grams > curve.maxGrams()) grams = curve.maxGrams();
    hal::Uart::write(',');
  }
  fw::newline();
}

// After a store: how it kept the old calibration through a power cut (or that it could not).
void sayStoreSafety(const tc::StoreReport& report, uint8_t slot) {
  if (report.spare_host != tc::kNoSlot) {
    say(TC_PSTR("# power-fail safe: the old calibration stayed loadable (a copy in motor "));
    fw::printUint(report.spare_host);
    sayLine(TC_PSTR("'s slot) until the new one was complete"));
  } else if (report.unprotected) {
    say(TC_PSTR("warning: motor "));
    fw::printUint(slot);
    sayLine(TC_PSTR(" was switched in place: the other three slots hold thesis records, so no "
                    "slot could keep the old calibration meanwhile (a power cut then leaves the "
                    "motor not calibrated, never flown wrong)"));
  }
}

}  // namespace

GatherStoreApp::GatherStoreApp() { sag_builder_.reset(settings_.pwm_min_us); }

void GatherStoreApp::begin() {
  for (uint8_t ch = 0; ch < hal::kEscChannels; ++ch) hal::Esc::writePulse(ch, kStopPwmUs);
  armed_at_ms_ = hal::Clock::millis();
  tc::readSettings<hal::Eeprom>(settings_board_);
  battery_ = tc::BatteryMonitor(settings_board_.batteryConfig());
  fw::newline();
  sayLine(TC_PSTR("thrustcal gather_store: Gather and Store (thesis sec. 6.4), 115200 8N1"));
  fw::printResetCause();
  sayLine(TC_PSTR("ESCs armed at 1000 us. Load cell A0, battery A1. Type help for the commands."));
  say(TC_PSTR("battery monitor: "));
  fw::printDivider(settings_board_);
  fw::newline();
  prompt();
}

void GatherStoreApp::prompt() { say(TC_PSTR("gs> ")); }

bool GatherStoreApp::poll() {
  hal::Watchdog::kick();  // the main loop came round
  const fw::LineEvent event = reader_.poll();
  if (event == fw::LineEvent::kNone) return false;
  // kRejected: the reader printed the one error line (damaged, not text, too long, checksum)
  if (event == fw::LineEvent::kLine) execute(reader_.line());
  prompt();
  return true;
}

// "error: <cmd> takes no arguments; nothing changed" unless the command came alone.
static bool alone(const char* cmd, uint8_t n) {
  if (n == 1) return true;
  say(TC_PSTR("error: "));
  hal::Uart::print(cmd);
  sayLine(TC_PSTR(" takes no arguments; nothing changed"));
  return false;
}

void GatherStoreApp::execute(char* line) {
  char* args[kMaxTokens];
  const uint8_t n = fw::tokenize(line, args, kMaxTokens);
  if (n == 0) return;  // empty line: just a new prompt
  const char* cmd = args[0];
  if (reader_.handleStrict(args, n)) return;
  // Strict mode: the commands that spin the motor or write the EEPROM need a checksum.
  const bool risky = fw::equalsP(cmd, TC_PSTR("sweep")) || fw::equalsP(cmd, TC_PSTR("store")) ||
                     fw::equalsP(cmd, TC_PSTR("erase")) ||
                     (n > 1 && fw::equalsP(cmd, TC_PSTR("divider")));
  if (risky && !reader_.allowRisky()) return;
  if (fw::equalsP(cmd, TC_PSTR("help"))) {
    if (alone(cmd, n)) cmdHelp();
  } else if (fw::equalsP(cmd, TC_PSTR("motor"))) {
    cmdMotor(args, n);
  } else if (fw::equalsP(cmd, TC_PSTR("plate"))) {
    cmdPlate(args, n);
  } else if (fw::equalsP(cmd, TC_PSTR("weigh"))) {
    if (alone(cmd, n)) cmdWeigh();
  } else if (fw::equalsP(cmd, TC_PSTR("tare"))) {
    if (alone(cmd, n)) cmdTare();
  } else if (fw::equalsP(cmd, TC_PSTR("cal"))) {
    cmdCal(args, n);
  } else if (fw::equalsP(cmd, TC_PSTR("span"))) {
    cmdSpan(args, n);
  } else if (fw::equalsP(cmd, TC_PSTR("range"))) {
    cmdRange(args, n);
  } else if (fw::equalsP(cmd, TC_PSTR("step"))) {
    cmdStep(args, n);
  } else if (fw::equalsP(cmd, TC_PSTR("settle"))) {
    cmdSettle(args, n);
  } else if (fw::equalsP(cmd, TC_PSTR("sweep"))) {
    if (alone(cmd, n)) cmdSweep();
  } else if (fw::equalsP(cmd, TC_PSTR("store"))) {
    cmdStore(args, n);
  } else if (fw::equalsP(cmd, TC_PSTR("show"))) {
    if (alone(cmd, n)) cmdShow();
  } else if (fw::equalsP(cmd, TC_PSTR("erase"))) {
    if (alone(cmd, n)) cmdErase();
  } else if (fw::equalsP(cmd, TC_PSTR("status"))) {
    if (alone(cmd, n)) cmdStatus();
  } else if (fw::equalsP(cmd, TC_PSTR("divider"))) {
    cmdDivider(args, n);
  } else if (fw::isEepromCommand(cmd)) {
    fw::eepromCommand(args, n);
  } else {
    say(TC_PSTR("error: unknown command '"));
    hal::Uart::print(cmd);
    sayLine(TC_PSTR("'; type help for the commands"));
  }
}

// ---------------------------------------------------------------------------------------
// Settings

void GatherStoreApp::cmdHelp() {
  sayLine(TC_PSTR("commands (one per line, numbers in decimal):"));
  sayLine(TC_PSTR("  help          this list"));
  sayLine(TC_PSTR("  motor N       select motor slot N (0..3): ESC output and EEPROM record"));
  sayLine(TC_PSTR("  plate G       plate weight in g, 0..500 (default 60)"));
  sayLine(TC_PSTR("  weigh         weight on the plate (median of 201 readings)"));
  sayLine(TC_PSTR("  cal W         calibrate: motor + propeller weigh W g (1..950); also tares"));
  sayLine(TC_PSTR("  tare          zerolize: force reads 0 g now (motor mounted, stopped)"));
  sayLine(TC_PSTR("  span W        optional gain: after tare put W g on the plate, then span W"));
  sayLine(TC_PSTR("  range MIN MAX sweep PWM range in us, 1000..2000 (default 1000 1800)"));
  sayLine(TC_PSTR("  step US       sweep step in us, 1..100 (default 10)"));
  sayLine(TC_PSTR("  settle MS     wait per step in ms, 0..10000 (thesis: 200); also the cap"));
  sayLine(TC_PSTR("  settle auto   next step once the force stops changing (default, cap 500)"));
  sayLine(TC_PSTR("  sweep         run the sweep, stream CSV; any key aborts (motor -> 1000 us)"));
  sayLine(TC_PSTR("  store 1       store the last sweep as curve 1 (+ start voltage, sag offsets)"));
  sayLine(TC_PSTR("  store 2       store the last sweep as curve 2 (another battery voltage)"));
  sayLine(TC_PSTR("  store v2      fit model v2 (effective voltage) to the last sweep and store it;"));
  sayLine(TC_PSTR("                a slot's v2 model from another voltage (>= 0.5 V) is refined"));
  sayLine(TC_PSTR("  show          what the selected slot's EEPROM record holds (v1 or v2)"));
  sayLine(TC_PSTR("  erase         mark the selected slot not calibrated (v1 and both v2 copies)"));
  sayLine(TC_PSTR("  status        settings, live force and battery, last sweep, stack"));
  sayLine(TC_PSTR("  eeprom crc|dump  EEPROM CRC-16 per slot and whole, or all of it as Intel HEX"));
  sayLine(TC_PSTR("  divider [R1 R2] battery divider in ohm, R1 pack-A1, R2 A1-ground (default"));
  sayLine(TC_PSTR("                100000 47000: 15.638 V); read_run flies with it too"));
  sayLine(TC_PSTR("  strict on|off sweep, store, erase and divider need a checksum (host clients)"));
  sayLine(TC_PSTR("lines: CR, LF or CRLF, at most 48 characters; optional checksum *HH = XOR"));
  sayLine(TC_PSTR("of the line before '*'; a damaged line is rejected whole (docs/console.md)"));
}

void GatherStoreApp::cmdMotor(char** args, uint8_t n) {
  int32_t slot;
  if (!oneArg(args, n, TC_PSTR("motor N (N = 0..3)"), TC_PSTR("motor slot"), 0,
              tc::kMotorSlots - 1, slot))
    return;
  settings_.slot = static_cast<uint8_t>(slot);
  say(TC_PSTR("motor "));
  fw::printUint(settings_.slot);
  say(TC_PSTR(" selected: ESC "));
  printEscPin(settings_.slot);
  say(TC_PSTR(", "));
  printRecordRange(settings_.slot);
  fw::newline();
}

void GatherStoreApp::cmdPlate(char** args, uint8_t n) {
  int32_t grams;
  if (!oneArg(args, n, TC_PSTR("plate G (e.g. plate 60)"), TC_PSTR("plate weight in g"), 0,
              kPlateMaxG, grams))
    return;
  settings_.plate_g = static_cast<int16_t>(grams);
  cell_.setPlateGrams(settings_.plate_g);
  say(TC_PSTR("plate "));
  fw::printInt(grams);
  sayLine(TC_PSTR(" g (weigh and cal leave it out)"));
}

void GatherStoreApp::cmdRange(char** args, uint8_t n) {
  if (n != 3) {
    usageError(TC_PSTR("range MIN MAX (e.g. range 1000 1800)"));
    return;
  }
  int32_t lo, hi;
  if (!fw::parseInt(args[1], kPwmLowestUs, kPwmHighestUs - 1, lo)) {
    rangeError(TC_PSTR("range MIN in us"), kPwmLowestUs, kPwmHighestUs - 1, args[1]);
    return;
  }
  if (!fw::parseInt(args[2], lo + 1, kPwmHighestUs, hi)) {
    rangeError(TC_PSTR("range MAX in us"), lo + 1, kPwmHighestUs, args[2]);
    return;
  }
  const uint32_t samples = static_cast<uint32_t>(hi - lo) / settings_.step_us + 1u;
  if (samples > kMaxSweepSamples) {
    say(TC_PSTR("error: that range is "));
    fw::printUint(samples);
    say(TC_PSTR(" steps of "));
    fw::printUint(settings_.step_us);
    say(TC_PSTR(" us, at most "));
    fw::printUint(kMaxSweepSamples);
    say(TC_PSTR(" fit: set a step of at least "));
    fw::printUint((static_cast<uint32_t>(hi - lo) + kMaxSweepSamples - 2u) / (kMaxSweepSamples - 1u));
    sayLine(TC_PSTR(" us first; nothing changed"));
    return;
  }
  settings_.pwm_min_us = static_cast<uint16_t>(lo);
  settings_.pwm_max_us = static_cast<uint16_t>(hi);
  say(TC_PSTR("range "));
  fw::printInt(lo);
  say(TC_PSTR(".."));
  fw::printInt(hi);
  say(TC_PSTR(" us, "));
  fw::printUint(plannedSamples());
  sayLine(TC_PSTR(" steps"));
}

void GatherStoreApp::cmdStep(char** args, uint8_t n) {
  int32_t step;
  if (!oneArg(args, n, TC_PSTR("step US (e.g. step 10)"), TC_PSTR("step in us"), kStepMinUs,
              kStepMaxUs, step))
    return;
  const uint32_t samples =
      static_cast<uint32_t>(settings_.pwm_max_us - settings_.pwm_min_us) / step + 1u;
  if (samples > kMaxSweepSamples) {
    say(TC_PSTR("error: a step of "));
    fw::printInt(step);
    say(TC_PSTR(" us makes "));
    fw::printUint(samples);
    say(TC_PSTR(" steps, at most "));
    fw::printUint(kMaxSweepSamples);
    sayLine(TC_PSTR(" fit: use a larger step or a smaller range; nothing changed"));
    return;
  }
  settings_.step_us = static_cast<uint16_t>(step);
  say(TC_PSTR("step "));
  fw::printInt(step);
  say(TC_PSTR(" us, "));
  fw::printUint(plannedSamples());
  sayLine(TC_PSTR(" steps"));
}

void GatherStoreApp::cmdSettle(char** args, uint8_t n) {
  int32_t ms;
  if (n == 2 && fw::equalsP(args[1], TC_PSTR("auto"))) {
    settings_.settle_auto = true;
    say(TC_PSTR("settle auto: next step once "));
    fw::printUint(kSettledAgreements + 1u);
    say(TC_PSTR(" force medians "));
    fw::printUint(kSettleProbeMs);
    say(TC_PSTR(" ms apart agree within "));
    fw::printUint(kSettledCounts);
    say(TC_PSTR(" counts, at most "));
    fw::printUint(settings_.settle_ms);
    sayLine(TC_PSTR(" ms per step (settle MS sets the cap and turns auto off)"));
    return;
  }
  if (!oneArg(args, n, TC_PSTR("settle MS | settle auto (e.g. settle 200)"),
              TC_PSTR("settle time in ms"),
              kSettleMinMs, kSettleMaxMs, ms))
    return;
  settings_.settle_ms = static_cast<uint16_t>(ms);
  settings_.settle_auto = false;
  say(TC_PSTR("settle "));
  fw::printInt(ms);
  sayLine(TC_PSTR(" ms per step"));
}

// ---------------------------------------------------------------------------------------
// Load cell (thesis phase 1: weigh and calibrate; phase 2: zerolize)

uint16_t GatherStoreApp::medianForceCounts() {
  force_median_.reset();
  for (uint16_t i = 0; i < kForceWindow; ++i) {
    hal::Watchdog::kick();  // 201 conversions: 21 ms
    force_median_.push(hal::Adc::readCounts(hal::kAdcLoadCell));
  }
  return force_median_.median();
}

uint16_t GatherStoreApp::medianBatteryCounts() {
  battery_median_.reset();
  for (uint16_t i = 0; i < kBatteryWindow; ++i) {
    hal::Watchdog::kick();
    battery_median_.push(hal::Adc::readCounts(hal::kAdcBattery));
  }
  return battery_median_.median();
}

bool GatherStoreApp::readSaneCell(uint16_t& counts) {
  counts = medianForceCounts();
  if (cell_.check(counts) != tc::LoadCellStatus::kImplausible) return true;
  say(TC_PSTR("error: load cell reads "));
  fw::printUint(counts);
  sayLine(TC_PSTR(" counts (ADC rail): check the amplifier supply and the wire to A0; "
                  "nothing changed"));
  return false;
}

void GatherStoreApp::cmdWeigh() {
  uint16_t counts;
  if (!readSaneCell(counts)) return;
  say(TC_PSTR("weight "));
  fw::printInt(cell_.weightGrams(counts));
  say(TC_PSTR(" g (plate "));
  fw::printInt(settings_.plate_g);
  say(TC_PSTR(" g left out), "));
  fw::printUint(counts);
  say(TC_PSTR(" counts"));
  if (cell_.isTared()) {
    say(TC_PSTR(", force "));
    fw::printFixed(divRound(cell_.forceMilligramsQ4(forceQ4()), 100), 1);
    say(TC_PSTR(" g"));
  }
  fw::newline();
}

void GatherStoreApp::tareAt(uint16_t counts) {
  cell_.tareQ4(forceQ4());
  tare_counts_ = counts;  // the empty point of a later span
}

void GatherStoreApp::cmdTare() {
  uint16_t counts;
  if (!readSaneCell(counts)) return;
  tareAt(counts);
  say(TC_PSTR("tared: force reads 0.0 g now ("));
  fw::printUint(counts);
  sayLine(TC_PSTR(" counts); ready to sweep"));
}

void GatherStoreApp::cmdCal(char** args, uint8_t n) {
  int32_t grams;
  if (!oneArg(args, n, TC_PSTR("cal W (W = motor + propeller in g, e.g. cal 95)"),
              TC_PSTR("known weight in g"), 1, cell_.config().overload_g, grams))
    return;
  uint16_t counts;
  if (!readSaneCell(counts)) return;
  cell_.calibrateWeight(counts, static_cast<int16_t>(grams));  // in range: cannot fail
  // Thesis: after calibration the program zerolizes and reads force upwards (phase 2).
  tareAt(counts);
  say(TC_PSTR("calibrated: motor + propeller weigh "));
  fw::printInt(grams);
  sayLine(TC_PSTR(" g; tared (force 0.0 g): ready to sweep"));
}

void GatherStoreApp::cmdSpan(char** args, uint8_t n) {
  int32_t grams;
  if (!oneArg(args, n, TC_PSTR("span W (W = known weight in g, e.g. span 200)"),
              TC_PSTR("known weight in g"), 1, cell_.config().overload_g, grams))
    return;
  if (!cell_.isTared()) {
    sayLine(TC_PSTR("error: span needs a tare first: tare, put the known weight on the "
                    "plate, then span W; nothing changed"));
    return;
  }
  uint16_t counts;
  if (!readSaneCell(counts)) return;
  if (!cell_.calibrateSpan(tare_counts_, counts, static_cast<int16_t>(grams))) {
    say(TC_PSTR("error: the reading moved from "));
    fw::printUint(tare_counts_);
    say(TC_PSTR(" to "));
    fw::printUint(counts);
    sayLine(TC_PSTR(" counts: a known weight must lower it by at least 10 counts at "
                    "0.25..3 g per count; put the weight on the plate and try again; "
                    "nothing changed"));
    return;
  }
  say(TC_PSTR("span: "));
  fw::printFixed(cell_.config().slope_ug_per_count, 6);
  sayLine(TC_PSTR(" g per count; remove the weight, then tare before the sweep"));
}

// ---------------------------------------------------------------------------------------
// Sweep (thesis: for every PWM, settle, read force and battery, keep them)

uint16_t GatherStoreApp::plannedSamples() const {
  return static_cast<uint16_t>((settings_.pwm_max_us - settings_.pwm_min_us) / settings_.step_us +
                               1u);
}

void GatherStoreApp::stopMotor() { hal::Esc::writePulse(settings_.slot, kStopPwmUs); }

bool GatherStoreApp::waitOrAbort(uint16_t ms) {
  const uint32_t start = hal::Clock::millis();
  for (;;) {
    hal::Watchdog::kick();  // settling: up to 10 s per step
    if (hal::Uart::available()) {
      abortSweep(SweepEnd::kKey, kKeyUnread);
      return false;
    }
    if (hal::Clock::millis() - start >= ms) return true;
    hal::Clock::sleepUntilInterrupt();
  }
}

void GatherStoreApp::printSettle() {
  say(settings_.settle_auto ? TC_PSTR("settle auto (cap ") : TC_PSTR("settle "));
  fw::printUint(settings_.settle_ms);
  say(settings_.settle_auto ? TC_PSTR(" ms)") : TC_PSTR(" ms"));
}

bool GatherStoreApp::settleForce(uint16_t& counts) {
  const uint32_t start = hal::Clock::millis();
  uint16_t previous = 0;
  bool have_previous = false;
  uint8_t agreements = 0;
  for (;;) {
    if (!waitOrAbort(kSettleProbeMs)) return false;
    if (!readForceCounts(counts)) return false;
    if (have_previous) {
      const uint16_t change = counts > previous ? counts - previous : previous - counts;
      agreements = change <= kSettledCounts ? static_cast<uint8_t>(agreements + 1) : 0;
      if (agreements >= kSettledAgreements) return true;
    }
    previous = counts;
    have_previous = true;
    if (hal::Clock::millis() - start >= settings_.settle_ms) return true;  // the cap
  }
}

bool GatherStoreApp::readForceCounts(uint16_t& counts) {
  force_median_.reset();
  for (uint16_t i = 0; i < kForceWindow; ++i) {
    hal::Watchdog::kick();
    if (hal::Uart::available()) {
      abortSweep(SweepEnd::kKey, kKeyUnread);
      return false;
    }
    force_median_.push(hal::Adc::readCounts(hal::kAdcLoadCell));
  }
  counts = force_median_.median();
  return true;
}

bool GatherStoreApp::readBatteryCounts(uint16_t& counts) {
  battery_median_.reset();
  for (uint16_t i = 0; i < kBatteryWindow; ++i) {
    hal::Watchdog::kick();
    if (hal::Uart::available()) {
      abortSweep(SweepEnd::kKey, kKeyUnread);
      return false;
    }
    battery_median_.push(hal::Adc::readCounts(hal::kAdcBattery));
  }
  counts = battery_median_.median();
  return true;
}

void GatherStoreApp::abortSweep(SweepEnd why, uint16_t value) {
  stopMotor();  // first, before any output
  last_end_ = why;
  sweep_.valid = false;
  sweep_.complete = false;
  // The key that aborted is not a command, nor is the rest of its line (e.g. "xerase").
  if (why == SweepEnd::kKey)
    reader_.abortLine(value == kKeyUnread ? hal::Uart::read() : static_cast<int16_t>(value));
  say(TC_PSTR("# aborted: "));
  switch (why) {
    case SweepEnd::kKey:
      say(TC_PSTR("key pressed"));
      break;
    case SweepEnd::kOverload:
      say(TC_PSTR("load cell overload, force "));
      fw::printInt(static_cast<int16_t>(value));
      say(TC_PSTR(" g (limit "));
      fw::printInt(cell_.config().overload_g);
      say(TC_PSTR(" g): lower range MAX"));
      break;
    case SweepEnd::kImplausible:
      say(TC_PSTR("load cell reads "));
      fw::printUint(value);
      say(TC_PSTR(" counts (ADC rail): check the amplifier and the wire to A0"));
      break;
    case SweepEnd::kBattery:
      say(TC_PSTR("battery reads "));
      fw::sayVolts(value);
      say(TC_PSTR(", outside "));
      fw::sayVolts(battery_.config().min_sane_mv);
      say(TC_PSTR(".."));
      fw::sayVolts(battery_.config().max_sane_mv);
      say(TC_PSTR(": check the pack and the divider on A1"));
      break;
    case SweepEnd::kDone:
      break;
  }
  sayLine(TC_PSTR("; motor stopped (1000 us), nothing kept: type sweep to start again"));
}

// pwm_us,force_g,vbat_v,t_s,motor,dir (dir 1: PWM rising)
static void printCsvRow(uint16_t pwm_us, int16_t force_dg, uint16_t vbat_mv, uint32_t t_ms,
                        uint8_t slot) {
  fw::printUint(pwm_us);
  hal::Uart::write(',');
  fw::printFixed(force_dg, 1);
  hal::Uart::write(',');
  fw::printFixed(vbat_mv, 3);
  hal::Uart::write(',');
  fw::printFixed(static_cast<int32_t>(t_ms), 3);
  hal::Uart::write(',');
  fw::printUint(slot);
  say(TC_PSTR(",1"));
  fw::newline();
}

void GatherStoreApp::cmdSweep() {
  if (!cell_.isTared()) {
    sayLine(TC_PSTR("error: a sweep needs a tare first: with the motor mounted and stopped, "
                    "type tare (or cal W)"));
    return;
  }
  const uint16_t planned = plannedSamples();
  if (planned > kMaxSweepSamples) {  // range and step refuse this already; kept as a guard
    sayLine(TC_PSTR("error: too many steps for the sample buffer: use a larger step"));
    return;
  }
  const uint8_t slot = settings_.slot;
  sweep_.valid = false;
  sweep_.complete = false;
  if (!swallowLineFeed()) return;
  scratch_.startBuilder();
  sag_builder_.reset(settings_.pwm_min_us);
  fitter_.reset();

  say(TC_PSTR("# sweep motor "));
  fw::printUint(slot);
  say(TC_PSTR(": "));
  fw::printUint(settings_.pwm_min_us);
  say(TC_PSTR(".."));
  fw::printUint(settings_.pwm_max_us);
  say(TC_PSTR(" us, step "));
  fw::printUint(settings_.step_us);
  say(TC_PSTR(" us, "));
  printSettle();
  say(TC_PSTR(", "));
  fw::printUint(planned);
  sayLine(TC_PSTR(" steps; any key aborts"));
  if (planned > kMaxV2Samples) {
    say(TC_PSTR("# note: model v2 keeps at most "));
    fw::printUint(kMaxV2Samples);
    sayLine(TC_PSTR(" steps: store v2 will refuse this sweep (store 1 and store 2 work)"));
  }

  const uint32_t since_arm = hal::Clock::millis() - armed_at_ms_;
  if (since_arm < kArmMs) {
    sayLine(TC_PSTR("# arming the ESC (1000 us)"));
    if (!waitOrAbort(static_cast<uint16_t>(kArmMs - since_arm))) return;
  }

  sayLine(TC_PSTR("pwm_us,force_g,vbat_v,t_s,motor,dir"));
  const uint32_t start_ms = hal::Clock::millis();
  uint16_t pwm = settings_.pwm_min_us;
  int16_t max_force_dg = 0;
  for (uint16_t done = 1; done <= planned;
       ++done, pwm = static_cast<uint16_t>(pwm + settings_.step_us)) {
    int16_t force_dg;
    uint16_t vbat_mv;
    if (!measureStep(pwm, force_dg, vbat_mv)) return;  // aborted, motor already stopped
    scratch_.builder().add(pwm, force_dg);
    sag_builder_.add(pwm, vbat_mv);
    fitter_.add(pwm, force_dg, vbat_mv);  // false once full: store v2 then refuses the sweep
    if (force_dg > max_force_dg) max_force_dg = force_dg;
    printCsvRow(pwm, force_dg, vbat_mv, hal::Clock::millis() - start_ms, slot);
    if (done % kProgressEvery == 0 && done != planned) {
      say(TC_PSTR("# "));
      fw::printUint(done);
      hal::Uart::write('/');
      fw::printUint(planned);
      say(TC_PSTR(" steps, max force "));
      fw::printFixed(max_force_dg, 1);
      sayLine(TC_PSTR(" g"));
    }
  }
  stopMotor();
  last_end_ = SweepEnd::kDone;
  finishSweep(slot, hal::Clock::millis() - start_ms);
}

bool GatherStoreApp::swallowLineFeed() {
  // A terminal that ends lines with CR LF sends the LF right after the CR that completed
  // "sweep" (87 us later at 115200 baud): it belongs to the command, it is not a key.
  const uint32_t start = hal::Clock::millis();
  while (!hal::Uart::available() && hal::Clock::millis() - start < kLineEndGraceMs) {
    hal::Clock::sleepUntilInterrupt();
  }
  if (!hal::Uart::available()) return true;
  const int16_t item = hal::Uart::read();
  if (item == '\n') return true;
  abortSweep(SweepEnd::kKey, static_cast<uint16_t>(item));  // a key: the motor has not started
  return false;
}

bool GatherStoreApp::measureStep(uint16_t pwm_us, int16_t& force_dg, uint16_t& vbat_mv) {
  hal::Esc::writePulse(settings_.slot, pwm_us);
  uint16_t force_counts;
  if (settings_.settle_auto) {
    if (!settleForce(force_counts)) return false;
  } else {
    if (!waitOrAbort(settings_.settle_ms)) return false;
    if (!readForceCounts(force_counts)) return false;
  }
  const tc::LoadCellStatus cell_status = cell_.check(force_counts);
  if (cell_status == tc::LoadCellStatus::kImplausible) {
    abortSweep(SweepEnd::kImplausible, force_counts);
    return false;
  }
  if (cell_status == tc::LoadCellStatus::kOverload) {
    abortSweep(SweepEnd::kOverload, static_cast<uint16_t>(cell_.forceGrams(force_counts)));
    return false;
  }
  const uint16_t force_q4 = forceQ4();  // the window whose median force_counts is
  uint16_t battery_counts;
  if (!readBatteryCounts(battery_counts)) return false;
  vbat_mv = battery_.millivoltsFromCounts(battery_counts);
  if (!battery_.isSane(vbat_mv)) {
    abortSweep(SweepEnd::kBattery, vbat_mv);
    return false;
  }
  force_dg = static_cast<int16_t>(divRound(cell_.forceMilligramsQ4(force_q4), 100));
  return true;
}

// Filter functions (fig. 6.9 and G.2): sag offsets and start voltage, then the force curve;
// then the summary lines.
void GatherStoreApp::finishSweep(uint8_t slot, uint32_t elapsed_ms) {
  uint16_t start_mv = 0;
  sweep_.sag = tc::SagTable();
  sag_builder_.build(sweep_.sag, start_mv);  // bin 0 holds the first step: cannot fail
  sweep_.curve.start_mv = start_mv;
  sweep_.samples = scratch_.builder().size();
  sweep_.report = scratch_.builder().build(sweep_.curve);
  sweep_.slot = slot;
  sweep_.complete = true;

  say(TC_PSTR("# done: "));
  fw::printUint(sweep_.samples);
  say(TC_PSTR(" samples in "));
  fw::printFixed(static_cast<int32_t>(elapsed_ms / 100u), 1);
  sayLine(TC_PSTR(" s, motor stopped (1000 us)"));
  say(TC_PSTR("# max force "));
  fw::printFixed(sweep_.report.max_force_dg, 1);
  say(TC_PSTR(" g (monotone fit), violations "));
  fw::printUint(sweep_.report.violations);
  say(TC_PSTR(", start voltage "));
  fw::sayVolts(start_mv);
  say(TC_PSTR(", sag in the top bin "));
  const int16_t top_sag_mv = sweep_.sag.offset_mv[tc::kSagBins - 1];
  fw::sayVolts(static_cast<uint16_t>(top_sag_mv > 0 ? top_sag_mv : 0));
  fw::newline();
  if (sweep_.report.status != tc::BuildStatus::kOk) {
    say(TC_PSTR("# no curve: "));
    printBuildProblem(sweep_.report.status);
    return;
  }
  sweep_.valid = true;
  say(TC_PSTR("# curve 1.."));
  fw::printUint(sweep_.curve.maxGrams());
  say(TC_PSTR(" g: 1 g at "));
  fw::printUint(sweep_.curve.pwmForGrams(1));
  say(TC_PSTR(" us, "));
  fw::printUint(sweep_.curve.maxGrams());
  say(TC_PSTR(" g at "));
  fw::printUint(sweep_.curve.pwmForGrams(sweep_.curve.maxGrams()));
  sayLine(TC_PSTR(" us"));
  say(TC_PSTR("# next: store 1 (first curve) or store 2 (second curve) for motor "));
  fw::printUint(slot);
  sayLine(TC_PSTR(", or store v2 (model v2)"));
}

// ---------------------------------------------------------------------------------------
// EEPROM record (thesis "First or second?")

bool GatherStoreApp::checkStoreSource(uint8_t slot) {
  if (!sweep_.complete) {
    sayLine(TC_PSTR("error: nothing to store: run a complete sweep first"));
    return false;
  }
  if (sweep_.slot != slot) {
    say(TC_PSTR("error: the last sweep was on motor "));
    fw::printUint(sweep_.slot);
    say(TC_PSTR(" but motor "));
    fw::printUint(slot);
    say(TC_PSTR(" is selected: type motor "));
    fw::printUint(sweep_.slot);
    sayLine(TC_PSTR(" or sweep again; nothing changed"));
    return false;
  }
  return true;
}

void GatherStoreApp::cmdStore(char** args, uint8_t n) {
  if (n == 2 && fw::equalsP(args[1], TC_PSTR("v2"))) {
    cmdStoreV2();
    return;
  }
  int32_t which;
  if (!oneArg(args, n, TC_PSTR("store 1 | store 2 | store v2"), TC_PSTR("curve number"), 1, 2,
              which))
    return;
  const uint8_t slot = settings_.slot;
  if (!checkStoreSource(slot)) return;
  if (!sweep_.valid) {
    say(TC_PSTR("error: the last sweep gave no thesis curve ("));
    printBuildProblem(sweep_.report.status);  // ends the line
    return;
  }
  const tc::RecordLimits limits = settings_board_.recordLimits();
  const bool had_v2 = tc::probeSlotLayout<hal::Eeprom>(slot, limits) == tc::SlotLayout::kModelV2;
  tc::MotorCalibration& record = scratch_.startRecord();
  const tc::DecodeStatus before = tc::readRecord<hal::Eeprom>(slot, record, limits);
  if (which == 1) {
    if (before != tc::DecodeStatus::kOk) record.clear();
    record.first = sweep_.curve;
    record.sag = sweep_.sag;
  } else {
    if (had_v2) {
      say(TC_PSTR("error: motor "));
      fw::printUint(slot);
      sayLine(TC_PSTR(" holds model v2, not a thesis curve 1: store 1 first (it replaces "
                      "model v2), or store v2; nothing changed"));
      return;
    }
    if (before != tc::DecodeStatus::kOk) {
      say(TC_PSTR("error: motor "));
      fw::printUint(slot);
      say(TC_PSTR(" has no first curve ("));
      hal::Uart::print(tc::decodeStatusText(before));
      sayLine(TC_PSTR("): store 1 first; nothing changed"));
      return;
    }
    const int32_t span_mv =
        absolute(static_cast<int32_t>(sweep_.curve.start_mv) - record.first.start_mv);
    const uint16_t min_span_mv = tc::ForcePwmLimits().min_voltage_span_mv;
    if (span_mv < min_span_mv) {
      say(TC_PSTR("error: this sweep started at "));
      fw::sayVolts(sweep_.curve.start_mv);
      say(TC_PSTR(", within "));
      fw::sayVolts(min_span_mv);
      say(TC_PSTR(" of curve 1 ("));
      fw::sayVolts(record.first.start_mv);
      sayLine(TC_PSTR("): sweep again at another battery voltage; nothing changed"));
      return;
    }
    record.second = sweep_.curve;
  }
  CountingEeprom::written = 0;
  const tc::StoreReport stored = tc::storeRecordV1<CountingEeprom>(slot, record, limits);
  if (stored.status == tc::StoreStatus::kImplausible) {
    say(TC_PSTR("error: curve "));
    fw::printInt(which);
    say(TC_PSTR(" of motor "));
    fw::printUint(slot);
    say(TC_PSTR(" cannot be right, "));
    fw::printRecordStatus(tc::DecodeStatus::kBadContent, stored.why);
    sayLine(TC_PSTR("; nothing stored: check the sweep (range, tare, divider) and sweep again"));
    return;
  }
  if (stored.status == tc::StoreStatus::kSettingsNoRoom) {
    say(TC_PSTR("error: motor "));
    fw::printUint(slot);
    sayLine(TC_PSTR("'s slot holds the divider setting and no other slot is free of thesis "
                    "records: a thesis record here would lose it; store v2 instead, or set "
                    "divider 100000 47000 first if that is the divider on A1; nothing changed"));
    return;
  }
  const tc::DecodeStatus after = tc::readRecord<hal::Eeprom>(slot, record, limits);
  if (stored.status != tc::StoreStatus::kStored || after != tc::DecodeStatus::kOk) {
    say(TC_PSTR("error: read-back of motor "));
    fw::printUint(slot);
    say(TC_PSTR("'s record failed ("));
    hal::Uart::print(tc::decodeStatusText(after));
    sayLine(TC_PSTR("): the EEPROM may be worn; try another slot"));
    return;
  }
  say(TC_PSTR("stored curve "));
  fw::printInt(which);
  say(TC_PSTR(" of motor "));
  fw::printUint(slot);
  say(TC_PSTR(" ("));
  printRecordRange(slot);
  say(TC_PSTR("): start "));
  fw::sayVolts(sweep_.curve.start_mv);
  say(TC_PSTR(", 1.."));
  fw::printUint(sweep_.curve.maxGrams());
  say(TC_PSTR(" g"));
  if (which == 1) {
    say(TC_PSTR(", sag offsets in 13 bins of 40 us from "));
    fw::printUint(record.sag.base_pwm_us);
    say(TC_PSTR(" us"));
    if (record.hasSecondCurve()) say(TC_PSTR("; curve 2 kept"));
  }
  if (had_v2) say(TC_PSTR("; replaced model v2 (the slot holds the thesis record now)"));
  sayWritten();
  sayStoreSafety(stored, slot);
}

// Model v2 (thrustcal/model_v2.hpp), fitted on the board; see the header for the rules.
void GatherStoreApp::cmdStoreV2() {
  const uint8_t slot = settings_.slot;
  if (!checkStoreSource(slot)) return;
  if (sweep_.samples > fitter_.capacity()) {
    say(TC_PSTR("error: the last sweep has "));
    fw::printUint(sweep_.samples);
    say(TC_PSTR(" steps, model v2 keeps at most "));
    fw::printUint(fitter_.capacity());
    say(TC_PSTR(" (SRAM): set a step of at least "));
    const uint16_t span_us = static_cast<uint16_t>(settings_.pwm_max_us - settings_.pwm_min_us);
    const uint16_t gaps = static_cast<uint16_t>(fitter_.capacity() - 1u);
    fw::printUint((span_us + gaps - 1u) / gaps);  // the smallest step that fits
    sayLine(TC_PSTR(" us for this range and sweep again; nothing changed"));
    return;
  }
  // What the slot holds now.
  const tc::RecordLimits limits = settings_board_.recordLimits();
  const tc::RecordV2Read now = tc::readModelV2<hal::Eeprom>(slot, model_, limits);
  const bool had_v2 = now.status == tc::DecodeStatus::kOk;
  const bool had_v1 = !had_v2 && hal::Eeprom::readByte(tc::slotAddress(slot)) == tc::kLayoutVersion1;
  const uint16_t old_rest_mv = model_.rest_mv;
  const uint16_t old_second_mv = model_.second_mv;
  const uint16_t old_start_q4 = model_.start_q4_us;
  const bool old_refined = had_v2 && (model_.flags & tc::kV2Refined) != 0;

  // This sweep alone (also gives its resting voltage). Each step below is shorter than the
  // watchdog's 64 ms (fit ~31 ms, refine ~17 ms, a slot read with its checks a few ms), the
  // whole command is not: the watchdog is kicked between them.
  hal::Watchdog::kick();
  tc::FitV2Report rep = fitter_.fit(model_);
  hal::Watchdog::kick();
  if (rep.status == tc::FitV2Status::kTooFewSamples || rep.status == tc::FitV2Status::kNoForce ||
      rep.status == tc::FitV2Status::kBadVoltage) {
    say(TC_PSTR("error: model v2 cannot use the last sweep: "));
    printFitProblem(rep.status);
    sayLine(TC_PSTR("; nothing changed"));
    return;
  }
  const uint16_t rest_mv = rep.rest_mv;
  const bool near_first = absolute(static_cast<int32_t>(rest_mv) - old_rest_mv) < kV2MinVoltageGapMv;
  const bool near_second =
      absolute(static_cast<int32_t>(rest_mv) - old_second_mv) < kV2MinVoltageGapMv;
  if (old_refined && near_second && !near_first) {
    say(TC_PSTR("error: motor "));
    fw::printUint(slot);
    say(TC_PSTR(" already holds a model v2 refined by a sweep at "));
    fw::sayVolts(old_second_mv);
    say(TC_PSTR(", within 0.5 V of this one ("));
    fw::sayVolts(rest_mv);
    sayLine(TC_PSTR("): sweep at another voltage, or erase and store v2 to start over; "
                    "nothing changed"));
    return;
  }
  const bool refine = had_v2 && !near_first;
  if (refine) {
    tc::readModelV2<hal::Eeprom>(slot, model_, limits);  // valid a moment ago
    hal::Watchdog::kick();
    rep = fitter_.refine(model_);
    hal::Watchdog::kick();
  }
  if (rep.status != tc::FitV2Status::kOk) {
    say(refine ? TC_PSTR("error: refining motor ") : TC_PSTR("error: fitting model v2 of motor "));
    fw::printUint(slot);
    say(TC_PSTR(" failed: "));
    printFitProblem(rep.status);
    sayLine(TC_PSTR("; check the sweep (range down to the ESC start, step 10 us); nothing changed"));
    return;
  }

  CountingEeprom::written = 0;
  const tc::StoreReport w = tc::storeModelV2<CountingEeprom>(slot, model_, limits);
  if (w.status == tc::StoreStatus::kUnchanged) {
    say(TC_PSTR("motor "));
    fw::printUint(slot);
    say(TC_PSTR(" already holds this model v2 ("));
    sayCopy(w.copy);
    say(TC_PSTR(", sequence "));
    fw::printUint(w.sequence);
    say(TC_PSTR("): nothing to write"));
    sayWritten();
    return;
  }
  if (w.status != tc::StoreStatus::kStored) {
    say(TC_PSTR("error: storing model v2 of motor "));
    fw::printUint(slot);
    if (w.status == tc::StoreStatus::kImplausible) {
      say(TC_PSTR(" refused: the model cannot be right, "));
      fw::printRecordStatus(tc::DecodeStatus::kBadContent, w.why);
      say(TC_PSTR("; check the sweep (range, tare, divider) and sweep again"));
    } else {
      say(w.status == tc::StoreStatus::kVerifyFailed
              ? TC_PSTR(" failed: read-back of the copy just written is bad (EEPROM worn?); "
                        "the previous copy is kept, try another slot")
              : TC_PSTR(" failed: the model is out of range; sweep again"));
    }
    sayWritten();
    return;
  }
  say(TC_PSTR("stored model v2 of motor "));
  fw::printUint(slot);
  say(TC_PSTR(" ("));
  printRecordRange(slot);
  say(TC_PSTR(", "));
  sayCopy(w.copy);
  say(TC_PSTR(", sequence "));
  fw::printUint(w.sequence);
  say(TC_PSTR("): "));
  if (refine) {
    say(TC_PSTR("refined with this sweep at "));
    fw::sayVolts(rest_mv);
    say(TC_PSTR(" (first sweep "));
    fw::sayVolts(model_.rest_mv);
    say(TC_PSTR("), start "));
    printQ4Us(model_.start_q4_us);
    say(TC_PSTR(" (was "));
    printQ4Us(old_start_q4);
    say(TC_PSTR(")"));
  } else {
    say(TC_PSTR("fitted from one sweep at "));
    fw::sayVolts(rest_mv);
    say(TC_PSTR(", start "));
    printQ4Us(model_.start_q4_us);
  }
  say(TC_PSTR(", curve to "));
  fw::printFixed(model_.maxForceDg(), 1);
  say(TC_PSTR(" g in "));
  fw::printUint(model_.knots);
  say(TC_PSTR(" knots"));
  if (had_v1) say(TC_PSTR("; replaced the thesis record"));
  if (had_v2 && !refine) {
    say(TC_PSTR("; replaced the model of a sweep at "));
    fw::sayVolts(old_rest_mv);
  }
  sayWritten();
  sayStoreSafety(w, slot);
  if (!refine) {
    say(TC_PSTR("# next: sweep at another voltage (>= 0.5 V from "));
    fw::sayVolts(rest_mv);
    sayLine(TC_PSTR("), then store v2 to refine"));
  }
}

void GatherStoreApp::showV2(uint8_t slot) {
  const tc::RecordV2Read r = tc::readModelV2<hal::Eeprom>(slot, model_, settings_board_.recordLimits());
  say(TC_PSTR("motor "));
  fw::printUint(slot);
  say(TC_PSTR(" ("));
  printRecordRange(slot);
  say(TC_PSTR("): "));
  if (r.status != tc::DecodeStatus::kOk) {
    say(TC_PSTR("not calibrated: v2 record, both copies bad ("));
    for (uint8_t copy = 0; copy < 2; ++copy) {
      if (copy) say(TC_PSTR(", "));
      sayCopy(copy);
      hal::Uart::write(' ');
      hal::Uart::print(tc::decodeStatusText(r.copy_status[copy]));
    }
    say(TC_PSTR(")"));
    if (r.status == tc::DecodeStatus::kBadContent && !r.why.ok()) {
      say(TC_PSTR(": "));
      fw::printRecordStatus(r.status, r.why);
    }
    fw::newline();
    return;
  }
  say(TC_PSTR("calibrated, model v2 ("));
  if (tc::isSpareCopy(r.copy)) {
    say(TC_PSTR("the copy kept in motor "));
    fw::printUint(tc::spareHost(slot, r.copy));
    say(TC_PSTR("'s slot, sequence "));
    fw::printUint(r.sequence);
    sayLine(TC_PSTR(": a store was cut short; the next store or erase settles it)"));
  } else {
    sayCopy(r.copy);
    say(TC_PSTR(", sequence "));
    fw::printUint(r.sequence);
    say(TC_PSTR("; other copy "));
    hal::Uart::print(tc::decodeStatusText(r.copy_status[r.copy ^ 1u]));
    sayLine(TC_PSTR(")"));
  }
  say(TC_PSTR("model v2: start "));
  printQ4Us(model_.start_q4_us);
  say(TC_PSTR(", curve to "));
  fw::printFixed(model_.maxForceDg(), 1);
  say(TC_PSTR(" g in "));
  fw::printUint(model_.knots);
  say(TC_PSTR(" knots, first sweep at "));
  fw::sayVolts(model_.rest_mv);
  if (model_.second_mv != 0) {
    say(TC_PSTR(", refined at "));
    fw::sayVolts(model_.second_mv);
  } else {
    say(TC_PSTR(", single sweep (store v2 after a sweep at another voltage refines it)"));
  }
  fw::newline();
  // What read_run sends for a step from rest: the bus voltage at the command predicted from
  // the bench sag.
  tc::BusVoltageFilter bus;
  bus.reset(model_.rest_mv);
  say(TC_PSTR("PWM from rest at "));
  fw::sayVolts(model_.rest_mv);
  say(TC_PSTR(" (bench sag predicted):"));
  const uint16_t max_g = static_cast<uint16_t>(model_.maxForceDg() / 10u);
  for (uint16_t grams = 10; grams <= max_g; grams = static_cast<uint16_t>(grams == 10 ? 100 : grams + 100)) {
    hal::Uart::write(' ');
    fw::printUint(grams);
    say(TC_PSTR(" g "));
    fw::printUint(tc::forceToPwmV2(model_, static_cast<uint16_t>(grams * 10u), bus, 0).pwm_us);
    say(TC_PSTR(" us"));
  }
  fw::newline();
}

void GatherStoreApp::cmdShow() {
  const uint8_t slot = settings_.slot;
  const tc::RecordLimits limits = settings_board_.recordLimits();
  if (tc::probeSlotLayout<hal::Eeprom>(slot, limits) == tc::SlotLayout::kModelV2) {
    showV2(slot);
    return;
  }
  tc::MotorCalibration& record = scratch_.startRecord();
  tc::Plausibility why;
  const tc::DecodeStatus status = tc::readRecord<hal::Eeprom>(slot, record, limits, &why);
  say(TC_PSTR("motor "));
  fw::printUint(slot);
  say(TC_PSTR(" ("));
  printRecordRange(slot);
  say(TC_PSTR("): "));
  if (status != tc::DecodeStatus::kOk) {
    say(TC_PSTR("not calibrated: "));
    fw::printRecordStatus(status, why);
    fw::newline();
    return;
  }
  sayLine(record.hasSecondCurve() ? TC_PSTR("calibrated, two curves")
                                   : TC_PSTR("calibrated, one curve"));
  printCurve(1, record.first);
  say(TC_PSTR("sag offsets in mV per 40 us from "));
  fw::printUint(record.sag.base_pwm_us);
  say(TC_PSTR(" us:"));
  for (uint8_t i = 0; i < tc::kSagBins; ++i) {
    hal::Uart::write(' ');
    fw::printInt(record.sag.offset_mv[i]);
  }
  fw::newline();
  if (record.hasSecondCurve()) {
    printCurve(2, record.second);
  } else {
    sayLine(TC_PSTR("curve 2: none (store 2 after a sweep at another battery voltage)"));
  }
}

void GatherStoreApp::cmdErase() {
  const uint8_t slot = settings_.slot;
  CountingEeprom::written = 0;
  // Both v2 copies' version bytes (the one not holding the newest model first); copy A's is
  // the thesis record's too.
  tc::eraseSlot<CountingEeprom>(slot, settings_board_.recordLimits());
  say(TC_PSTR("erased motor "));
  fw::printUint(slot);
  say(TC_PSTR(" ("));
  printRecordRange(slot);
  say(TC_PSTR("): not calibrated now, thesis curves, sag offsets and model v2 are gone"));
  sayWritten();
}

void GatherStoreApp::cmdStatus() {
  say(TC_PSTR("motor "));
  fw::printUint(settings_.slot);
  say(TC_PSTR(" (ESC "));
  printEscPin(settings_.slot);
  say(TC_PSTR(" at "));
  fw::printUint(hal::Esc::pulseUs(settings_.slot));
  say(TC_PSTR(" us), plate "));
  fw::printInt(settings_.plate_g);
  say(TC_PSTR(" g, range "));
  fw::printUint(settings_.pwm_min_us);
  say(TC_PSTR(".."));
  fw::printUint(settings_.pwm_max_us);
  say(TC_PSTR(" us, step "));
  fw::printUint(settings_.step_us);
  say(TC_PSTR(" us, "));
  printSettle();
  fw::newline();

  const uint16_t counts = medianForceCounts();
  say(TC_PSTR("load cell "));
  fw::printUint(counts);
  say(TC_PSTR(" counts"));
  if (cell_.check(counts) == tc::LoadCellStatus::kImplausible) {
    say(TC_PSTR(" (ADC rail: check A0)"));
  } else if (cell_.isTared()) {
    say(TC_PSTR(", force "));
    fw::printFixed(divRound(cell_.forceMilligramsQ4(forceQ4()), 100), 1);
    say(TC_PSTR(" g"));
  } else {
    say(TC_PSTR(", weight "));
    fw::printInt(cell_.weightGrams(counts));
    say(TC_PSTR(" g, not tared"));
  }
  say(TC_PSTR("; battery "));
  fw::sayVolts(battery_.millivoltsFromCounts(medianBatteryCounts()));
  fw::newline();

  say(TC_PSTR("last sweep: "));
  if (!sweep_.valid) {
    sayLine(TC_PSTR("none kept"));
  } else {
    say(TC_PSTR("motor "));
    fw::printUint(sweep_.slot);
    say(TC_PSTR(", "));
    fw::printUint(sweep_.samples);
    say(TC_PSTR(" samples, max force "));
    fw::printFixed(sweep_.report.max_force_dg, 1);
    say(TC_PSTR(" g, curve 1.."));
    fw::printUint(sweep_.curve.maxGrams());
    sayLine(TC_PSTR(" g (store 1, store 2 or store v2 saves it)"));
  }
  fw::printHealth(reader_);
}

// `divider [R1 R2]`: the battery monitor's divider (thrustcal/board_settings.hpp). The last
// sweep's volts came through the old one: it is dropped when the divider changes.
void GatherStoreApp::cmdDivider(char** args, uint8_t n) {
  if (!fw::commandDivider(args, n, settings_board_)) return;
  battery_ = tc::BatteryMonitor(settings_board_.batteryConfig());
  if (sweep_.complete) {
    sweep_.valid = false;
    sweep_.complete = false;
    sayLine(TC_PSTR("note: the last sweep was measured with the old divider and is dropped: "
                    "sweep again before store"));
  }
}

}  // namespace gs

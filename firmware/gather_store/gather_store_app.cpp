// Gather and Store console (see gather_store_app.hpp for the flow and the rules): start-up,
// the line loop, and the EEPROM record commands store 1|2, store v2, show and erase: read the
// slot, ask the store decision (store_decision.hpp), write through thrustcal/eeprom_store.hpp,
// hand the outcome to the view (gather_store_view.hpp). Thesis "First or second?" (fig. 6.8)
// and model v2. (Start-up reads the board settings here too: one copy of the settings
// codec's constants in SRAM for both.)
//
// The rest: the command table gather_store_commands.cpp, the settings and load-cell commands
// settings_commands.cpp, the sweep sweep_runner.cpp, the printing gather_store_view.cpp and
// store_view.cpp.
#include "record_report.hpp"
#include "gather_store_app.hpp"
#include "gather_store_view.hpp"
#include "hal/hal.hpp"
#include "store_decision.hpp"
#include "thrustcal/eeprom_store.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/record_v2.hpp"

namespace gs {

namespace {

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

using fw::say;
using fw::sayLine;

}  // namespace

GatherStoreApp::GatherStoreApp() { sag_builder_.reset(sweep_settings_.pwm_min_us); }

void GatherStoreApp::begin() {
  for (uint8_t ch = 0; ch < hal::kEscChannels; ++ch) hal::Esc::writePulse(ch, kStopPwmUs);
  armed_at_ms_ = hal::Clock::millis();
  tc::readSettings<hal::Eeprom>(board_settings_);
  battery_ = tc::BatteryMonitor(board_settings_.batteryConfig());
  fw::newline();
  say(TC_FLASH_TEXT("thrustcal gather_store: Gather and Store (thesis sec. 6.4), "));
  fw::printUint(hal::kUartBaud);
  sayLine(TC_FLASH_TEXT(" 8N1"));
  fw::printResetCause();
  sayLine(TC_FLASH_TEXT("ESCs armed at 1000 us. Load cell A0, battery A1. Type help for the commands."));
  say(TC_FLASH_TEXT("battery monitor: "));
  fw::printDivider(board_settings_);
  fw::newline();
  prompt();
}

void GatherStoreApp::prompt() { say(TC_FLASH_TEXT("gs> ")); }

bool GatherStoreApp::poll() {
  hal::Watchdog::kick();  // the main loop came round
  const fw::LineEvent event = reader_.poll();
  if (event == fw::LineEvent::kNone) return false;
  // kRejected: the reader printed the one error line (damaged, not text, too long, checksum)
  if (event == fw::LineEvent::kLine) execute(reader_.line());
  prompt();
  return true;
}

void GatherStoreApp::execute(char* line) {
  fw::LineContext context;
  context.checksummed = reader_.checked();
  context.strict = reader_.strict();
  runCommand(line, context);  // the table: gather_store_commands.cpp
}

// ---------------------------------------------------------------------------------------
// EEPROM record (thesis "First or second?")

bool GatherStoreApp::refuse(StoreRefusal why, const view::RefusalFacts& facts) {
  if (why == StoreRefusal::kNone) return false;
  view::sayRefusal(why, sweep_, facts);
  return true;
}

void GatherStoreApp::cmdStore(uint8_t which) {
  const uint8_t slot = sweep_settings_.slot;
  view::RefusalFacts facts;
  facts.slot = slot;
  if (refuse(checkStoreSource(sweep_, slot), facts)) return;
  const tc::RecordLimits limits = board_settings_.recordLimits();
  const bool had_v2 = tc::probeSlotLayout<hal::Eeprom>(slot, limits) == tc::SlotLayout::kModelV2;
  tc::MotorCalibration& record = scratch_.startRecord();
  facts.before = tc::readRecord<hal::Eeprom>(slot, record, limits);
  hal::Watchdog::kick();  // the slot's decode (~15 ms) and the store's own checks: kicked between
  facts.limit = tc::ForcePwmLimits().min_voltage_span_mv;
  facts.this_mv = sweep_.curve.start_mv;
  facts.other_mv = record.first.start_mv;
  if (refuse(planStoreV1(which, sweep_, had_v2, facts.before, facts.limit, record), facts)) return;

  view::V1Outcome outcome;
  outcome.which = which;
  outcome.slot = slot;
  outcome.had_v2 = had_v2;
  CountingEeprom::written = 0;
  const tc::StoreReport report = tc::storeRecordV1<CountingEeprom>(slot, record, limits);
  outcome.written = CountingEeprom::written;
  if (report.status != tc::StoreStatus::kImplausible &&
      report.status != tc::StoreStatus::kSettingsNoRoom) {
    outcome.after = tc::readRecord<hal::Eeprom>(slot, record, limits);
    hal::Watchdog::kick();  // read back (waiting out the last byte's write): then the report
  }
  view::sayV1Outcome(outcome, report, sweep_, record);
}

// Model v2 (thrustcal/model_v2.hpp), fitted on the board; see the header for the rules.
void GatherStoreApp::cmdStoreV2() {
  const uint8_t slot = sweep_settings_.slot;
  view::RefusalFacts facts;
  facts.slot = slot;
  if (refuse(checkStoreSource(sweep_, slot), facts)) return;
  if (sweep_.samples > fitter_.capacity()) {
    facts.limit = fitter_.capacity();
    facts.step_us = smallestStepUs(
        static_cast<uint16_t>(sweep_settings_.pwm_max_us - sweep_settings_.pwm_min_us), fitter_.capacity());
    refuse(StoreRefusal::kTooManySamples, facts);
    return;
  }
  // What the slot holds now.
  const tc::RecordLimits limits = board_settings_.recordLimits();
  const tc::RecordV2Read now = tc::readModelV2<hal::Eeprom>(slot, model_, limits);
  SlotContents before;
  before.has_v2 = now.status == tc::DecodeStatus::kOk;
  before.has_v1 =
      !before.has_v2 && hal::Eeprom::readByte(tc::slotAddress(slot)) == tc::kLayoutVersion1;
  before.refined = before.has_v2 && (model_.flags & tc::kV2Refined) != 0;
  before.rest_mv = model_.rest_mv;
  before.second_mv = model_.second_mv;
  before.start_q4_us = model_.start_q4_us;

  // This sweep alone (also gives its resting voltage). Each step below is shorter than the
  // watchdog's 64 ms (fit ~31 ms, refine ~17 ms, a slot read with its checks a few ms), the
  // whole command is not: the watchdog is kicked between them.
  hal::Watchdog::kick();
  tc::FitV2Report rep = fitter_.fit(model_);
  hal::Watchdog::kick();
  if (fitRulesOutSweep(rep.status)) {
    facts.fit = rep.status;
    refuse(StoreRefusal::kFitUnusable, facts);
    return;
  }
  const V2Action action = decideV2(before, rep.rest_mv, tc::kV2MinVoltageGapMv);
  if (action == V2Action::kRefuse) {
    facts.other_mv = before.second_mv;
    facts.this_mv = rep.rest_mv;
    facts.limit = tc::kV2MinVoltageGapMv;
    refuse(StoreRefusal::kRefinedNear, facts);
    return;
  }
  view::V2Outcome outcome;
  outcome.slot = slot;
  outcome.refine = action == V2Action::kRefine;
  outcome.before = before;
  outcome.rest_mv = rep.rest_mv;
  if (outcome.refine) {
    tc::readModelV2<hal::Eeprom>(slot, model_, limits);  // valid a moment ago
    hal::Watchdog::kick();
    rep = fitter_.refine(model_);
    hal::Watchdog::kick();
  }
  if (rep.status != tc::FitV2Status::kOk) {
    view::sayV2FitFailed(slot, outcome.refine, rep.status);
    return;
  }
  // A new fit from a sweep corrected with this slot's dynamics keeps them (a refine read them).
  if (!outcome.refine && sweep_.lag_corrected) model_.dynamics = lag_dynamics_;
  CountingEeprom::written = 0;
  const tc::StoreReport report = tc::storeModelV2<CountingEeprom>(slot, model_, limits);
  outcome.written = CountingEeprom::written;
  view::sayV2Outcome(outcome, report, model_);
}

void GatherStoreApp::cmdShow() {
  const uint8_t slot = sweep_settings_.slot;
  const tc::RecordLimits limits = board_settings_.recordLimits();
  if (tc::probeSlotLayout<hal::Eeprom>(slot, limits) == tc::SlotLayout::kModelV2) {
    const tc::RecordV2Read read = tc::readModelV2<hal::Eeprom>(slot, model_, limits);
    view::showModelV2(slot, read, model_);
    return;
  }
  tc::MotorCalibration& record = scratch_.startRecord();
  tc::Plausibility why;
  const tc::DecodeStatus status = tc::readRecord<hal::Eeprom>(slot, record, limits, &why);
  view::showRecordV1(slot, status, why, record);
}

void GatherStoreApp::cmdErase() {
  const uint8_t slot = sweep_settings_.slot;
  CountingEeprom::written = 0;
  // Both v2 copies' version bytes (the one not holding the newest model first); copy A's is
  // the thesis record's too.
  tc::eraseSlot<CountingEeprom>(slot, board_settings_.recordLimits());
  fw::say(TC_FLASH_TEXT("erased "));
  view::sayMotorRecord(slot);  // "motor N (EEPROM a..b): "
  fw::say(TC_FLASH_TEXT("not calibrated now, thesis curves, sag offsets and model v2 are gone"));
  view::sayWritten(CountingEeprom::written);
}

}  // namespace gs

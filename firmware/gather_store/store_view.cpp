// The console view of the store commands (see gather_store_view.hpp): refusals and outcomes
// of store 1|2 and store v2. Print code only.
#include "gather_store_view.hpp"

#include "hal/hal.hpp"
#include "record_report.hpp"

namespace gs {
namespace view {

using fw::say;
using fw::sayCopy;
using fw::sayLine;

void sayRefusal(StoreRefusal why, const SweepResult& sweep, const RefusalFacts& facts) {
  switch (why) {
    case StoreRefusal::kNone:
      return;
    case StoreRefusal::kNoSweep:
      sayLine(TC_FLASH_TEXT("error: nothing to store: run a complete sweep first"));
      return;
    case StoreRefusal::kOtherSlot:
      say(TC_FLASH_TEXT("error: the last sweep was on motor "));
      fw::printUint(sweep.slot);
      say(TC_FLASH_TEXT(" but motor "));
      fw::printUint(facts.slot);
      say(TC_FLASH_TEXT(" is selected: type motor "));
      fw::printUint(sweep.slot);
      sayLine(TC_FLASH_TEXT(" or sweep again; nothing changed"));
      return;
    case StoreRefusal::kNoThesisCurve:
      say(TC_FLASH_TEXT("error: the last sweep gave no thesis curve ("));
      printBuildProblem(sweep.report.status);  // ends the line
      return;
    case StoreRefusal::kSlotHoldsV2:
      say(TC_FLASH_TEXT("error: motor "));
      fw::printUint(facts.slot);
      sayLine(TC_FLASH_TEXT(" holds model v2, not a thesis curve 1: store 1 first (it replaces "
                      "model v2), or store v2; nothing changed"));
      return;
    case StoreRefusal::kNoFirstCurve:
      say(TC_FLASH_TEXT("error: motor "));
      fw::printUint(facts.slot);
      say(TC_FLASH_TEXT(" has no first curve ("));
      hal::Uart::print(tc::decodeStatusText(facts.before));
      sayLine(TC_FLASH_TEXT("): store 1 first; nothing changed"));
      return;
    case StoreRefusal::kVoltagesTooClose:
      say(TC_FLASH_TEXT("error: this sweep started at "));
      fw::sayVolts(facts.this_mv);
      say(TC_FLASH_TEXT(", within "));
      fw::sayVolts(facts.limit);
      say(TC_FLASH_TEXT(" of curve 1 ("));
      fw::sayVolts(facts.other_mv);
      sayLine(TC_FLASH_TEXT("): sweep again at another battery voltage; nothing changed"));
      return;
    case StoreRefusal::kTooManySamples:
      say(TC_FLASH_TEXT("error: the last sweep has "));
      fw::printUint(sweep.samples);
      say(TC_FLASH_TEXT(" steps, model v2 keeps at most "));
      fw::printUint(facts.limit);
      say(TC_FLASH_TEXT(" (SRAM): set a step of at least "));
      fw::printUint(facts.step_us);
      sayLine(TC_FLASH_TEXT(" us for this range and sweep again; nothing changed"));
      return;
    case StoreRefusal::kFitUnusable:
      say(TC_FLASH_TEXT("error: model v2 cannot use the last sweep: "));
      printFitProblem(facts.fit);
      sayLine(TC_FLASH_TEXT("; nothing changed"));
      return;
    case StoreRefusal::kRefinedNear:
      say(TC_FLASH_TEXT("error: motor "));
      fw::printUint(facts.slot);
      say(TC_FLASH_TEXT(" already holds a model v2 refined by a sweep at "));
      fw::sayVolts(facts.other_mv);
      say(TC_FLASH_TEXT(", within "));
      fw::sayVolts(facts.limit);
      say(TC_FLASH_TEXT(" of this one ("));
      fw::sayVolts(facts.this_mv);
      sayLine(TC_FLASH_TEXT("): sweep at another voltage, or erase and store v2 to start over; "
                      "nothing changed"));
      return;
  }
}

void sayV1Outcome(const V1Outcome& outcome, const tc::StoreReport& report,
                  const SweepResult& sweep, const tc::MotorCalibration& record) {
  const uint8_t slot = outcome.slot;
  if (report.status == tc::StoreStatus::kImplausible) {
    say(TC_FLASH_TEXT("error: curve "));
    fw::printInt(outcome.which);
    say(TC_FLASH_TEXT(" of motor "));
    fw::printUint(slot);
    say(TC_FLASH_TEXT(" cannot be right, "));
    fw::printRecordStatus(tc::DecodeStatus::kBadContent, report.why);
    sayLine(TC_FLASH_TEXT("; nothing stored: check the sweep (range, tare, divider) and sweep again"));
    return;
  }
  if (report.status == tc::StoreStatus::kSettingsNoRoom) {
    say(TC_FLASH_TEXT("error: motor "));
    fw::printUint(slot);
    sayLine(TC_FLASH_TEXT("'s slot holds the divider setting and no other slot is free of thesis "
                    "records: a thesis record here would lose it; store v2 instead, or set "
                    "divider 100000 47000 first if that is the divider on A1; nothing changed"));
    return;
  }
  if (report.status != tc::StoreStatus::kStored ||
      outcome.after != tc::DecodeStatus::kOk) {
    say(TC_FLASH_TEXT("error: read-back of motor "));
    fw::printUint(slot);
    say(TC_FLASH_TEXT("'s record failed ("));
    hal::Uart::print(tc::decodeStatusText(outcome.after));
    sayLine(TC_FLASH_TEXT("): the EEPROM may be worn; try another slot"));
    return;
  }
  say(TC_FLASH_TEXT("stored curve "));
  fw::printInt(outcome.which);
  say(TC_FLASH_TEXT(" of motor "));
  fw::printUint(slot);
  say(TC_FLASH_TEXT(" ("));
  printRecordRange(slot);
  say(TC_FLASH_TEXT("): start "));
  fw::sayVolts(sweep.curve.start_mv);
  say(TC_FLASH_TEXT(", 1.."));
  fw::printUint(sweep.curve.maxGrams());
  say(TC_FLASH_TEXT(" g"));
  if (outcome.which == 1) {
    say(TC_FLASH_TEXT(", sag offsets in "));
    fw::printUint(tc::kSagBins);
    say(TC_FLASH_TEXT(" bins of "));
    fw::printUint(tc::kSagBinWidthUs);
    say(TC_FLASH_TEXT(" us from "));
    fw::printUint(record.sag.base_pwm_us);
    say(TC_FLASH_TEXT(" us"));
    if (record.hasSecondCurve()) say(TC_FLASH_TEXT("; curve 2 kept"));
  }
  if (outcome.had_v2) say(TC_FLASH_TEXT("; replaced model v2 (the slot holds the thesis record now)"));
  sayWritten(outcome.written);
  sayStoreSafety(report, slot);
}

void sayV2FitFailed(uint8_t slot, bool refine, tc::FitV2Status status) {
  say(refine ? TC_FLASH_TEXT("error: refining motor ") : TC_FLASH_TEXT("error: fitting model v2 of motor "));
  fw::printUint(slot);
  say(TC_FLASH_TEXT(" failed: "));
  printFitProblem(status);
  sayLine(TC_FLASH_TEXT("; check the sweep (range down to the ESC start, step 10 us); nothing changed"));
}

void sayV2Outcome(const V2Outcome& outcome, const tc::StoreReport& w,
                  const tc::ModelV2& model) {
  const uint8_t slot = outcome.slot;
  if (w.status == tc::StoreStatus::kUnchanged) {
    say(TC_FLASH_TEXT("motor "));
    fw::printUint(slot);
    say(TC_FLASH_TEXT(" already holds this model v2 ("));
    sayCopy(w.copy);
    say(TC_FLASH_TEXT(", sequence "));
    fw::printUint(w.sequence);
    say(TC_FLASH_TEXT("): nothing to write"));
    sayWritten(outcome.written);
    return;
  }
  if (w.status != tc::StoreStatus::kStored) {
    say(TC_FLASH_TEXT("error: storing model v2 of motor "));
    fw::printUint(slot);
    if (w.status == tc::StoreStatus::kImplausible) {
      say(TC_FLASH_TEXT(" refused: the model cannot be right, "));
      fw::printRecordStatus(tc::DecodeStatus::kBadContent, w.why);
      say(TC_FLASH_TEXT("; check the sweep (range, tare, divider) and sweep again"));
    } else {
      say(w.status == tc::StoreStatus::kVerifyFailed
              ? TC_FLASH_TEXT(" failed: read-back of the copy just written is bad (EEPROM worn?); "
                        "the previous copy is kept, try another slot")
              : TC_FLASH_TEXT(" failed: the model is out of range; sweep again"));
    }
    sayWritten(outcome.written);
    return;
  }
  say(TC_FLASH_TEXT("stored model v2 of motor "));
  fw::printUint(slot);
  say(TC_FLASH_TEXT(" ("));
  printRecordRange(slot);
  say(TC_FLASH_TEXT(", "));
  sayCopy(w.copy);
  say(TC_FLASH_TEXT(", sequence "));
  fw::printUint(w.sequence);
  say(TC_FLASH_TEXT("): "));
  if (outcome.refine) {
    say(TC_FLASH_TEXT("refined with this sweep at "));
    fw::sayVolts(outcome.rest_mv);
    say(TC_FLASH_TEXT(" (first sweep "));
    fw::sayVolts(model.rest_mv);
    say(TC_FLASH_TEXT("), start "));
    printQ4Us(model.start_q4_us);
    say(TC_FLASH_TEXT(" (was "));
    printQ4Us(outcome.before.start_q4_us);
    say(TC_FLASH_TEXT(")"));
  } else {
    say(TC_FLASH_TEXT("fitted from one sweep at "));
    fw::sayVolts(outcome.rest_mv);
    say(TC_FLASH_TEXT(", start "));
    printQ4Us(model.start_q4_us);
  }
  say(TC_FLASH_TEXT(", curve to "));
  fw::printFixed(model.maxForceDg(), 1);
  say(TC_FLASH_TEXT(" g in "));
  fw::printUint(model.knots);
  say(TC_FLASH_TEXT(" knots"));
  if (outcome.before.has_v1) say(TC_FLASH_TEXT("; replaced the thesis record"));
  if (outcome.before.has_v2 && !outcome.refine) {
    say(TC_FLASH_TEXT("; replaced the model of a sweep at "));
    fw::sayVolts(outcome.before.rest_mv);
  }
  sayWritten(outcome.written);
  sayStoreSafety(w, slot);
  if (!outcome.refine) {
    say(TC_FLASH_TEXT("# next: sweep at another voltage (>= "));
    fw::sayVolts(tc::kV2MinVoltageGapMv);
    say(TC_FLASH_TEXT(" from "));
    fw::sayVolts(outcome.rest_mv);
    sayLine(TC_FLASH_TEXT("), then store v2 to refine"));
  }
}

}  // namespace view
}  // namespace gs

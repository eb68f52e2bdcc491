// The console view of gather_store (see gather_store_view.hpp): print code only.
#include "gather_store_view.hpp"

#include "hal/hal.hpp"
#include "record_report.hpp"
#include "thrustcal/force_pwm.hpp"

namespace gs {
namespace view {

using fw::say;
using fw::sayCopy;
using fw::sayLine;

void sayWritten(uint16_t bytes) {
  say(TC_FLASH_TEXT("; wrote "));
  fw::printUint(bytes);
  sayLine(bytes == 1 ? TC_FLASH_TEXT(" byte") : TC_FLASH_TEXT(" bytes"));
}

// 1/16 us -> "1083.4 us"
void printQ4Us(uint16_t q4_us) {
  fw::printFixed(static_cast<int32_t>((static_cast<uint32_t>(q4_us) * 10u + 8u) >> 4), 1);
  say(TC_FLASH_TEXT(" us"));
}

void printRecordRange(uint8_t slot) {
  say(TC_FLASH_TEXT("EEPROM "));
  fw::printUint(tc::slotAddress(slot));
  say(TC_FLASH_TEXT(".."));
  fw::printUint(tc::slotAddress(slot) + tc::kRecordBytes - 1u);
}


void sayMotorRecord(uint8_t slot) {
  say(TC_FLASH_TEXT("motor "));
  fw::printUint(slot);
  say(TC_FLASH_TEXT(" ("));
  printRecordRange(slot);
  say(TC_FLASH_TEXT("): "));
}

// Why model v2 could not use a sweep (flash copies of tc::fitV2StatusText's reasons: the core's
// texts are plain strings, which the AVR keeps in SRAM).
void printFitProblem(tc::FitV2Status status) {
  switch (status) {
    case tc::FitV2Status::kOk: say(TC_FLASH_TEXT("ok")); break;
    case tc::FitV2Status::kTooFewSamples:
      say(TC_FLASH_TEXT("fewer than 8 PWM steps: widen the range or use a smaller step"));
      break;
    case tc::FitV2Status::kNoForce:
      say(TC_FLASH_TEXT("the force never reached 5 g: motor not spinning or cell not tared?"));
      break;
    case tc::FitV2Status::kBadVoltage:
      say(TC_FLASH_TEXT("a battery reading outside 3..26 V: check the monitor wiring on A1 and the "
                  "divider setting"));
      break;
    case tc::FitV2Status::kStartNotFound:
      say(TC_FLASH_TEXT("ESC start threshold not found: sweep from 1000 us to full force in "
                  "steps of at most 10 us"));
      break;
    case tc::FitV2Status::kVoltagesTooClose:
      say(TC_FLASH_TEXT("the two sweeps rested within "));
      fw::sayVolts(tc::kV2MinVoltageGapMv);
      say(TC_FLASH_TEXT(" of each other"));
      break;
    case tc::FitV2Status::kNoModel: say(TC_FLASH_TEXT("no model to refine")); break;
  }
}

void printBuildProblem(tc::BuildStatus status) {
  switch (status) {
    case tc::BuildStatus::kTooFewSamples:
      sayLine(TC_FLASH_TEXT("fewer than 2 PWM steps: widen the range (range MIN MAX)"));
      break;
    case tc::BuildStatus::kNoForce:
      sayLine(TC_FLASH_TEXT("the force never reached 1 g: check that the motor spins with its "
                      "propeller and that the cell was tared with the motor stopped"));
      break;
    case tc::BuildStatus::kCurveTooSteep:
      sayLine(TC_FLASH_TEXT("two neighbouring grams lie more than 254 us apart: use a smaller step"));
      break;
    case tc::BuildStatus::kOk:
      fw::newline();
      break;
  }
}

// "curve 1: start 12.600 V, 1..500 g; 1 g 1105 us, 100 g 1310 us, ..."
void printCurve(uint8_t which, const tc::ForceCurveBase& curve) {
  say(TC_FLASH_TEXT("curve "));
  fw::printUint(which);
  say(TC_FLASH_TEXT(": start "));
  fw::sayVolts(curve.start_mv);
  say(TC_FLASH_TEXT(", 1.."));
  fw::printUint(curve.maxGrams());
  say(TC_FLASH_TEXT(" g; PWM per gram:"));
  uint16_t grams = 1;
  for (;;) {
    hal::Uart::write(' ');
    fw::printUint(grams);
    say(TC_FLASH_TEXT(" g "));
    fw::printUint(curve.pwmForGrams(grams));
    say(TC_FLASH_TEXT(" us"));
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
    say(TC_FLASH_TEXT("# power-fail safe: the old calibration stayed loadable (a copy in motor "));
    fw::printUint(report.spare_host);
    sayLine(TC_FLASH_TEXT("'s slot) until the new one was complete"));
  } else if (report.unprotected) {
    say(TC_FLASH_TEXT("warning: motor "));
    fw::printUint(slot);
    sayLine(TC_FLASH_TEXT(" was switched in place: the other three slots hold thesis records, so no "
                    "slot could keep the old calibration meanwhile (a power cut then leaves the "
                    "motor not calibrated, never flown wrong)"));
  }
  if (report.params == tc::ParamsMove::kMoved) {
    say(TC_FLASH_TEXT("# fly's saved parameters moved out of motor "));
    fw::printUint(slot);
    sayLine(TC_FLASH_TEXT("'s slot first (they live in a slot without a thesis record)"));
  } else if (report.params == tc::ParamsMove::kDropped) {
    say(TC_FLASH_TEXT("warning: fly's saved parameters lived in motor "));
    fw::printUint(slot);
    sayLine(TC_FLASH_TEXT("'s slot and no other slot is free of thesis records: they are gone (fly "
                          "flies its defaults and says so; thrustcal board params push puts a "
                          "file back once a slot is free)"));
  }
}


// pwm_us,force_g,vbat_v,t_s,motor,dir (dir 1: PWM rising)
void printCsvRow(uint16_t pwm_us, int16_t force_dg, uint16_t vbat_mv, uint32_t t_ms,
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
  say(TC_FLASH_TEXT(",1"));
  fw::newline();
}

void sayProgress(uint16_t done, uint16_t planned, int16_t max_force_dg) {
  say(TC_FLASH_TEXT("# "));
  fw::printUint(done);
  hal::Uart::write('/');
  fw::printUint(planned);
  say(TC_FLASH_TEXT(" steps, max force "));
  fw::printFixed(max_force_dg, 1);
  sayLine(TC_FLASH_TEXT(" g"));
}

void saySweepSummary(const SweepResult& sweep, uint32_t elapsed_ms) {
  say(TC_FLASH_TEXT("# done: "));
  fw::printUint(sweep.samples);
  say(TC_FLASH_TEXT(" samples in "));
  fw::printFixed(static_cast<int32_t>(elapsed_ms / 100u), 1);
  sayLine(TC_FLASH_TEXT(" s, motor stopped (1000 us)"));
  say(TC_FLASH_TEXT("# max force "));
  fw::printFixed(sweep.report.max_force_dg, 1);
  say(TC_FLASH_TEXT(" g (monotone fit), violations "));
  fw::printUint(sweep.report.violations);
  say(TC_FLASH_TEXT(", start voltage "));
  fw::sayVolts(sweep.curve.start_mv);
  say(TC_FLASH_TEXT(", sag in the top bin "));
  const int16_t top_sag_mv = sweep.sag.offset_mv[tc::kSagBins - 1];
  fw::sayVolts(static_cast<uint16_t>(top_sag_mv > 0 ? top_sag_mv : 0));
  fw::newline();
  if (sweep.report.status != tc::BuildStatus::kOk) {
    say(TC_FLASH_TEXT("# no curve: "));
    printBuildProblem(sweep.report.status);
    return;
  }
  say(TC_FLASH_TEXT("# curve 1.."));
  fw::printUint(sweep.curve.maxGrams());
  say(TC_FLASH_TEXT(" g: 1 g at "));
  fw::printUint(sweep.curve.pwmForGrams(1));
  say(TC_FLASH_TEXT(" us, "));
  fw::printUint(sweep.curve.maxGrams());
  say(TC_FLASH_TEXT(" g at "));
  fw::printUint(sweep.curve.pwmForGrams(sweep.curve.maxGrams()));
  sayLine(TC_FLASH_TEXT(" us"));
  say(TC_FLASH_TEXT("# next: store 1 (first curve) or store 2 (second curve) for motor "));
  fw::printUint(sweep.slot);
  sayLine(TC_FLASH_TEXT(", or store v2 (model v2)"));
}

void showModelV2(uint8_t slot, const tc::RecordV2Read& r, const tc::ModelV2& model) {
  sayMotorRecord(slot);
  if (r.status != tc::DecodeStatus::kOk) {
    say(TC_FLASH_TEXT("not calibrated: v2 record, both copies bad ("));
    for (uint8_t copy = 0; copy < 2; ++copy) {
      if (copy) say(TC_FLASH_TEXT(", "));
      sayCopy(copy);
      hal::Uart::write(' ');
      hal::Uart::print(tc::decodeStatusText(r.copy_status[copy]));
    }
    say(TC_FLASH_TEXT(")"));
    if (r.status == tc::DecodeStatus::kBadContent && !r.why.ok()) {
      say(TC_FLASH_TEXT(": "));
      fw::printRecordStatus(r.status, r.why);
    }
    fw::newline();
    return;
  }
  say(TC_FLASH_TEXT("calibrated, model v2 ("));
  if (tc::isSpareCopy(r.copy)) {
    say(TC_FLASH_TEXT("the copy kept in motor "));
    fw::printUint(tc::spareHost(slot, r.copy));
    say(TC_FLASH_TEXT("'s slot, sequence "));
    fw::printUint(r.sequence);
    sayLine(TC_FLASH_TEXT(": a store was cut short; the next store or erase settles it)"));
  } else {
    sayCopy(r.copy);
    say(TC_FLASH_TEXT(", sequence "));
    fw::printUint(r.sequence);
    say(TC_FLASH_TEXT("; other copy "));
    hal::Uart::print(tc::decodeStatusText(r.copy_status[r.copy ^ 1u]));
    sayLine(TC_FLASH_TEXT(")"));
  }
  say(TC_FLASH_TEXT("model v2: start "));
  printQ4Us(model.start_q4_us);
  say(TC_FLASH_TEXT(", curve to "));
  fw::printFixed(model.maxForceDg(), 1);
  say(TC_FLASH_TEXT(" g in "));
  fw::printUint(model.knots);
  say(TC_FLASH_TEXT(" knots, first sweep at "));
  fw::sayVolts(model.rest_mv);
  if (model.second_mv != 0) {
    say(TC_FLASH_TEXT(", refined at "));
    fw::sayVolts(model.second_mv);
  } else {
    say(TC_FLASH_TEXT(", single sweep (store v2 after a sweep at another voltage refines it)"));
  }
  fw::newline();
  // What read_run sends for a step from rest: the bus voltage at the command predicted from
  // the bench sag.
  tc::BusVoltageFilter bus;
  bus.reset(model.rest_mv);
  say(TC_FLASH_TEXT("PWM from rest at "));
  fw::sayVolts(model.rest_mv);
  say(TC_FLASH_TEXT(" (bench sag predicted):"));
  const uint16_t max_g = static_cast<uint16_t>(model.maxForceDg() / 10u);
  for (uint16_t grams = 10; grams <= max_g;
       grams = static_cast<uint16_t>(grams == 10 ? 100 : grams + 100)) {
    hal::Uart::write(' ');
    fw::printUint(grams);
    say(TC_FLASH_TEXT(" g "));
    fw::printUint(tc::forceToPwmV2(model, static_cast<uint16_t>(grams * 10u), bus, 0).pwm_us);
    say(TC_FLASH_TEXT(" us"));
  }
  fw::newline();
  say(TC_FLASH_TEXT("dynamics: "));
  if (model.dynamics.isPresent()) {
    printDynamics(model.dynamics);
    fw::newline();
  } else {
    sayLine(TC_FLASH_TEXT("not measured (dyn measures them)"));
  }
}

void showRecordV1(uint8_t slot, tc::DecodeStatus status, const tc::Plausibility& why,
                  const tc::MotorCalibration& record) {
  sayMotorRecord(slot);
  if (status != tc::DecodeStatus::kOk) {
    say(TC_FLASH_TEXT("not calibrated: "));
    fw::printRecordStatus(status, why);
    fw::newline();
    return;
  }
  sayLine(record.hasSecondCurve() ? TC_FLASH_TEXT("calibrated, two curves")
                                   : TC_FLASH_TEXT("calibrated, one curve"));
  printCurve(1, record.first);
  say(TC_FLASH_TEXT("sag offsets in mV per "));
  fw::printUint(tc::kSagBinWidthUs);
  say(TC_FLASH_TEXT(" us from "));
  fw::printUint(record.sag.base_pwm_us);
  say(TC_FLASH_TEXT(" us:"));
  for (uint8_t i = 0; i < tc::kSagBins; ++i) {
    hal::Uart::write(' ');
    fw::printInt(record.sag.offset_mv[i]);
  }
  fw::newline();
  if (record.hasSecondCurve()) {
    printCurve(2, record.second);
  } else {
    sayLine(TC_FLASH_TEXT("curve 2: none (store 2 after a sweep at another battery voltage)"));
  }
}

void sayLagCorrected(int16_t largest_dg) {
  say(TC_FLASH_TEXT("# lag correction: largest shift of a reading "));
  fw::printFixed(largest_dg, 1);
  sayLine(TC_FLASH_TEXT(" g (the curve and model v2 use the corrected readings; the rows above are as read)"));
}

}  // namespace view

}  // namespace gs

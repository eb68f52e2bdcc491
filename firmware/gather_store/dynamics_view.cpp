// What dyn and dyn cell print (gather_store_view.hpp): the step log's CSV rows and comment lines
// (format: docs/gather_store.md, "The step log"), the fits, the summary and the refusals.
// Figures print in fixed point (no float formatting in the image).
#include "gather_store_view.hpp"
#include "hal/hal.hpp"

namespace gs {
namespace view {

using fw::say;
using fw::sayLine;

namespace {

void printDirWord(int8_t dir) { say(dir > 0 ? TC_FLASH_TEXT("up") : TC_FLASH_TEXT("down")); }

void printMs(float seconds) { fw::printFixed(tc::secondsTo01ms(seconds), 1); }  // "79.1"

void printGrams(float grams) {
  fw::printFixed(static_cast<int32_t>(grams * 10.0f + (grams < 0.0f ? -0.5f : 0.5f)), 1);
}

// Seconds since `session_us`, 4 decimals.
void printSessionTime(uint32_t at_us, uint32_t session_us) {
  fw::printFixed(static_cast<int32_t>((at_us - session_us + 50u) / 100u), 4);
}

void printPulses(const DynRecording& rec) {
  fw::printUint(rec.from_us);
  say(TC_FLASH_TEXT(" -> "));
  fw::printUint(rec.to_us);
  say(TC_FLASH_TEXT(" us"));
}

}  // namespace

void sayDynHeader() { sayLine(TC_FLASH_TEXT("t_s,pwm_us,force_g,vbat_v,motor,dir")); }

void printDynRows(const DynLog& log, const DynRecording& rec, uint32_t session_us, uint8_t slot, int8_t dir) {
  const uint32_t span_us = rec.end_us - rec.start_us;
  for (uint16_t b = 0; b < kDynLogBlocks; ++b) {
    const uint32_t at_us = rec.start_us + (span_us * (2u * b + 1u)) / (2u * kDynLogBlocks);
    printSessionTime(at_us, session_us);
    hal::Uart::write(',');
    const bool stepped = rec.edge_us != 0 && static_cast<int32_t>(at_us - rec.edge_us) >= 0;
    fw::printUint(rec.edge_us == 0 ? hal::Esc::pulseUs(slot) : (stepped ? rec.to_us : rec.from_us));
    hal::Uart::write(',');
    fw::printFixed(log.force_dg[b], 1);
    hal::Uart::write(',');
    fw::printFixed(log.vbat_mv[b / tc::kDynBlocksPerVbat], 3);
    hal::Uart::write(',');
    fw::printUint(slot);
    hal::Uart::write(',');
    fw::printInt(dir);
    fw::newline();
  }
}

void sayDynStep(int8_t dir, const DynRecording& rec, uint32_t session_us, uint16_t vbat_mv) {
  say(TC_FLASH_TEXT("# step "));
  printDirWord(dir);
  hal::Uart::write(' ');
  printPulses(rec);
  say(TC_FLASH_TEXT(" at t_s "));
  printSessionTime(rec.edge_us, session_us);
  say(TC_FLASH_TEXT(" (the ESC's edge); bus "));
  fw::sayVolts(vbat_mv);
  fw::newline();
}

void sayDynFit(int8_t dir, const DynRecording& rec, const tc::MotorStepFit& fit) {
  say(TC_FLASH_TEXT("# fit "));
  printDirWord(dir);
  hal::Uart::write(' ');
  printPulses(rec);
  if (!fit.ok()) {
    say(TC_FLASH_TEXT(": not usable: "));
    say(tc::stepFitWhyText(fit.why));
    sayLine(TC_FLASH_TEXT(" (this point is left out)"));
    return;
  }
  say(TC_FLASH_TEXT(" at "));
  printGrams(0.5f * (fit.from_g + fit.to_g));
  say(TC_FLASH_TEXT(" g: tau "));
  printMs(fit.tau_s);
  say(TC_FLASH_TEXT(" ms, "));
  printGrams(fit.from_g);
  say(TC_FLASH_TEXT(" -> "));
  printGrams(fit.to_g);
  say(TC_FLASH_TEXT(" g, residual "));
  fw::printFixed(static_cast<int32_t>(fit.rms_g * 100.0f + 0.5f), 2);
  sayLine(TC_FLASH_TEXT(" g"));
}

void printBenchResponse(const tc::BenchResponse& bench) {
  fw::printUint(bench.stages);
  say(bench.stages == 1 ? TC_FLASH_TEXT(" stage of ") : TC_FLASH_TEXT(" stages of "));
  fw::printFixed(bench.tau_01ms, 1);
  say(TC_FLASH_TEXT(" ms (mean delay "));
  fw::printFixed(static_cast<int32_t>(bench.tau_01ms) * bench.stages, 1);
  say(TC_FLASH_TEXT(" ms)"));
}

void printDynamics(const tc::MotorDynamics& d) {
  fw::printUint(d.points);
  say(TC_FLASH_TEXT(" points "));
  fw::printFixed(d.lo_dg, 1);
  say(TC_FLASH_TEXT(".."));
  fw::printFixed(d.hi_dg, 1);
  say(TC_FLASH_TEXT(" g: spin-up "));
  fw::printFixed(d.up_lo_01ms, 1);
  say(TC_FLASH_TEXT(" -> "));
  fw::printFixed(d.up_hi_01ms, 1);
  say(TC_FLASH_TEXT(" ms, spin-down "));
  fw::printFixed(d.down_lo_01ms, 1);
  say(TC_FLASH_TEXT(" -> "));
  fw::printFixed(d.down_hi_01ms, 1);
  say(TC_FLASH_TEXT(" ms"));
}

void sayCellFit(const tc::BenchStepFit& fit) {
  if (!fit.ok()) {
    say(TC_FLASH_TEXT("error: the weight step does not fit a load-cell response: "));
    say(tc::stepFitWhyText(fit.why));
    sayLine(TC_FLASH_TEXT("; lift the weight off in one quick move (or use a heavier one) and try again; nothing "
                          "changed"));
    return;
  }
  say(TC_FLASH_TEXT("# fit cell: step "));
  printGrams(fit.to_g - fit.from_g);
  say(TC_FLASH_TEXT(" g at t_s "));
  fw::printFixed(static_cast<int32_t>(fit.step_s * 1e4f + 0.5f), 4);
  say(TC_FLASH_TEXT(", residual "));
  fw::printFixed(static_cast<int32_t>(fit.rms_g * 100.0f + 0.5f), 2);
  sayLine(TC_FLASH_TEXT(" g"));
}

void sayCellStored(const tc::BenchResponse& bench, const tc::SettingsWrite& w) {
  say(TC_FLASH_TEXT("dyn cell: the load cell's response is "));
  printBenchResponse(bench);
  if (w.status == tc::SettingsWriteStatus::kWritten || w.status == tc::SettingsWriteStatus::kUnchanged) {
    say(TC_FLASH_TEXT("; stored with the board settings (motor "));
    fw::printUint(w.host);
    say(TC_FLASH_TEXT("'s slot, "));
    fw::sayCopy(w.copy);
    sayLine(TC_FLASH_TEXT(")"));
    return;
  }
  sayLine(w.status == tc::SettingsWriteStatus::kNoRoom
              ? TC_FLASH_TEXT("; not stored: all four slots hold thesis (v1) records, which fill the EEPROM; store "
                              "one motor as model v2 or erase one slot, then dyn cell again")
              : TC_FLASH_TEXT("; not stored: read-back failed (EEPROM worn?); the previous setting is kept"));
}

bool dynMayRun(bool tared, const tc::BenchResponse& bench, tc::DecodeStatus v2, uint8_t slot) {
  if (!tared) {
    sayLine(TC_FLASH_TEXT("error: dyn needs a tare first: with the motor mounted and stopped, type tare (or cal W)"));
    return false;
  }
  if (!bench.isValid()) {
    sayLine(TC_FLASH_TEXT("error: the load cell's own response is not known: run dyn cell once on this bench (a "
                          "weight lifted off the plate), then dyn"));
    return false;
  }
  if (v2 != tc::DecodeStatus::kOk) {
    say(TC_FLASH_TEXT("error: dyn needs motor "));
    fw::printUint(slot);
    sayLine(TC_FLASH_TEXT(" calibrated as model v2 (it picks its operating points from the model and stores the "
                          "dynamics with it): sweep, store v2, then dyn"));
    return false;
  }
  return true;
}

void sayDynPlan(uint8_t slot, uint16_t max_force_dg, const tc::BenchResponse& bench, uint16_t lo_us,
                uint16_t hi_us) {
  say(TC_FLASH_TEXT("# dyn motor "));
  fw::printUint(slot);
  say(TC_FLASH_TEXT(": 5 operating points at 20..80 % of "));
  fw::printFixed(max_force_dg, 1);
  say(TC_FLASH_TEXT(" g ("));
  fw::printUint(lo_us);
  say(TC_FLASH_TEXT(".."));
  fw::printUint(hi_us);
  say(TC_FLASH_TEXT(" us), each stepped from 0.9 to 1.1 of its force and back; bench: "));
  printBenchResponse(bench);
  sayLine(TC_FLASH_TEXT("; any key aborts (motor -> 1000 us)"));
}

void sayDynFailed(uint8_t slot, uint8_t points_ok) {
  say(TC_FLASH_TEXT("error: motor "));
  fw::printUint(slot);
  say(TC_FLASH_TEXT(": "));
  fw::printUint(points_ok);
  sayLine(TC_FLASH_TEXT(" operating points gave usable steps (at least 2 needed), or a time constant came out "
                        "beyond 5..2000 ms: check the mount and the log above; nothing stored"));
}

void sayDynStored(uint8_t slot, const tc::MotorDynamics& d, uint32_t session_ms, const tc::StoreReport& report) {
  say(TC_FLASH_TEXT("dyn motor "));
  fw::printUint(slot);
  say(TC_FLASH_TEXT(": "));
  printDynamics(d);
  say(TC_FLASH_TEXT(" (1/tau linear in sqrt(F)), session "));
  fw::printFixed(static_cast<int32_t>(session_ms / 100u), 1);
  sayLine(TC_FLASH_TEXT(" s"));
  if (report.status == tc::StoreStatus::kStored || report.status == tc::StoreStatus::kUnchanged) {
    say(TC_FLASH_TEXT("stored with motor "));
    fw::printUint(slot);
    say(TC_FLASH_TEXT("'s model v2 ("));
    fw::sayCopy(report.copy);
    sayLine(TC_FLASH_TEXT(")"));
    return;
  }
  sayLine(TC_FLASH_TEXT("error: not stored: the record's write failed (EEPROM worn?); the previous record is kept"));
}

}  // namespace view
}  // namespace gs

// The bench settings and load-cell commands of gather_store (thesis phase 1: weigh and
// calibrate; phase 2: zerolize), status and the divider setting. Every constant string goes
// through TC_FLASH_TEXT so it stays in flash on the AVR.
#include "gather_store_app.hpp"

#include "gather_store_view.hpp"
#include "hal/hal.hpp"
#include "record_report.hpp"
#include "store_decision.hpp"

namespace gs {

namespace {

using fw::say;
using fw::sayLine;

// Nearest integer of num / den (den > 0), halves away from zero.
int32_t divRound(int32_t num, int32_t den) {
  return num >= 0 ? (num + den / 2) / den : -((-num + den / 2) / den);
}

}  // namespace

int16_t GatherStoreApp::forceDecigrams(uint16_t force_q4) const {
  return static_cast<int16_t>(divRound(cell_.forceMilligramsQ4(force_q4), 100));
}

// ---------------------------------------------------------------------------------------
// Settings

void GatherStoreApp::cmdMotor(uint8_t slot) {
  sweep_settings_.slot = slot;
  say(TC_FLASH_TEXT("motor "));
  fw::printUint(sweep_settings_.slot);
  say(TC_FLASH_TEXT(" selected: ESC "));
  fw::printEscPin(sweep_settings_.slot);
  say(TC_FLASH_TEXT(", "));
  view::printRecordRange(sweep_settings_.slot);
  fw::newline();
}

void GatherStoreApp::cmdPlate(int16_t grams) {
  sweep_settings_.plate_g = grams;
  cell_.setPlateGrams(sweep_settings_.plate_g);
  say(TC_FLASH_TEXT("plate "));
  fw::printInt(grams);
  sayLine(TC_FLASH_TEXT(" g (weigh and cal leave it out)"));
}

// "range N..M us, K steps" / "step N us, K steps"
void GatherStoreApp::sayPlannedSteps() {
  say(TC_FLASH_TEXT(" us, "));
  fw::printUint(plannedSamples());
  sayLine(TC_FLASH_TEXT(" steps"));
}

void GatherStoreApp::cmdRange(uint16_t lo, uint16_t hi) {
  // Each bound's own range is the table's; that MAX lies above MIN is checked here.
  if (hi <= lo) {
    say(TC_FLASH_TEXT("error: range MAX must be above MIN ("));
    fw::printUint(lo);
    say(TC_FLASH_TEXT(" us), got "));
    fw::printUint(hi);
    sayLine(TC_FLASH_TEXT("; nothing changed"));
    return;
  }
  const uint32_t samples = static_cast<uint32_t>(hi - lo) / sweep_settings_.step_us + 1u;
  if (samples > kMaxSweepSamples) {
    say(TC_FLASH_TEXT("error: that range is "));
    fw::printUint(samples);
    say(TC_FLASH_TEXT(" steps of "));
    fw::printUint(sweep_settings_.step_us);
    say(TC_FLASH_TEXT(" us, at most "));
    fw::printUint(kMaxSweepSamples);
    say(TC_FLASH_TEXT(" fit: set a step of at least "));
    fw::printUint(smallestStepUs(static_cast<uint16_t>(hi - lo), kMaxSweepSamples));
    sayLine(TC_FLASH_TEXT(" us first; nothing changed"));
    return;
  }
  sweep_settings_.pwm_min_us = lo;
  sweep_settings_.pwm_max_us = hi;
  say(TC_FLASH_TEXT("range "));
  fw::printUint(lo);
  say(TC_FLASH_TEXT(".."));
  fw::printUint(hi);
  sayPlannedSteps();
}

void GatherStoreApp::cmdStep(uint16_t step) {
  const uint32_t samples =
      static_cast<uint32_t>(sweep_settings_.pwm_max_us - sweep_settings_.pwm_min_us) / step + 1u;
  if (samples > kMaxSweepSamples) {
    say(TC_FLASH_TEXT("error: a step of "));
    fw::printUint(step);
    say(TC_FLASH_TEXT(" us makes "));
    fw::printUint(samples);
    say(TC_FLASH_TEXT(" steps, at most "));
    fw::printUint(kMaxSweepSamples);
    sayLine(TC_FLASH_TEXT(" fit: use a larger step or a smaller range; nothing changed"));
    return;
  }
  sweep_settings_.step_us = step;
  say(TC_FLASH_TEXT("step "));
  fw::printUint(step);
  sayPlannedSteps();
}

void GatherStoreApp::cmdSettleAuto() {
  sweep_settings_.settle_auto = true;
  say(TC_FLASH_TEXT("settle auto: next step once "));
  fw::printUint(kSettledAgreements + 1u);
  say(TC_FLASH_TEXT(" force medians "));
  fw::printUint(kSettleProbeMs);
  say(TC_FLASH_TEXT(" ms apart agree within "));
  fw::printUint(kSettledCounts);
  say(TC_FLASH_TEXT(" counts, at most "));
  fw::printUint(sweep_settings_.settle_ms);
  sayLine(TC_FLASH_TEXT(" ms per step (settle MS sets the cap and turns auto off)"));
}

void GatherStoreApp::cmdSettle(uint16_t ms) {
  sweep_settings_.settle_ms = ms;
  sweep_settings_.settle_auto = false;
  say(TC_FLASH_TEXT("settle "));
  fw::printUint(ms);
  sayLine(TC_FLASH_TEXT(" ms per step"));
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
  say(TC_FLASH_TEXT("error: load cell reads "));
  fw::printUint(counts);
  sayLine(TC_FLASH_TEXT(" counts (ADC rail): check the amplifier supply and the wire to A0; "
                  "nothing changed"));
  return false;
}

void GatherStoreApp::cmdWeigh() {
  uint16_t counts;
  if (!readSaneCell(counts)) return;
  say(TC_FLASH_TEXT("weight "));
  fw::printInt(cell_.weightGrams(counts));
  say(TC_FLASH_TEXT(" g (plate "));
  fw::printInt(sweep_settings_.plate_g);
  say(TC_FLASH_TEXT(" g left out), "));
  fw::printUint(counts);
  say(TC_FLASH_TEXT(" counts"));
  if (cell_.isTared()) {
    say(TC_FLASH_TEXT(", force "));
    fw::printFixed(forceDecigrams(forceQ4()), 1);
    say(TC_FLASH_TEXT(" g"));
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
  say(TC_FLASH_TEXT("tared: force reads 0.0 g now ("));
  fw::printUint(counts);
  sayLine(TC_FLASH_TEXT(" counts); ready to sweep"));
}

void GatherStoreApp::cmdCal(int16_t grams) {
  uint16_t counts;
  if (!readSaneCell(counts)) return;
  cell_.calibrateWeight(counts, grams);  // in range: cannot fail
  // Thesis: after calibration the program zerolizes and reads force upwards (phase 2).
  tareAt(counts);
  say(TC_FLASH_TEXT("calibrated: motor + propeller weigh "));
  fw::printInt(grams);
  sayLine(TC_FLASH_TEXT(" g; tared (force 0.0 g): ready to sweep"));
}

void GatherStoreApp::cmdSpan(int16_t grams) {
  if (!cell_.isTared()) {
    sayLine(TC_FLASH_TEXT("error: span needs a tare first: tare, put the known weight on the "
                    "plate, then span W; nothing changed"));
    return;
  }
  uint16_t counts;
  if (!readSaneCell(counts)) return;
  if (!cell_.calibrateSpan(tare_counts_, counts, grams)) {
    say(TC_FLASH_TEXT("error: the reading moved from "));
    fw::printUint(tare_counts_);
    say(TC_FLASH_TEXT(" to "));
    fw::printUint(counts);
    sayLine(TC_FLASH_TEXT(" counts: a known weight must lower it by at least 10 counts at "
                    "0.25..3 g per count; put the weight on the plate and try again; "
                    "nothing changed"));
    return;
  }
  say(TC_FLASH_TEXT("span: "));
  fw::printFixed(cell_.config().slope_ug_per_count, 6);
  sayLine(TC_FLASH_TEXT(" g per count; remove the weight, then tare before the sweep"));
}


// ---------------------------------------------------------------------------------------
// Status and the board setting

void GatherStoreApp::cmdStatus() {
  say(TC_FLASH_TEXT("motor "));
  fw::printUint(sweep_settings_.slot);
  say(TC_FLASH_TEXT(" (ESC "));
  fw::printEscPin(sweep_settings_.slot);
  say(TC_FLASH_TEXT(" at "));
  fw::printUint(hal::Esc::pulseUs(sweep_settings_.slot));
  say(TC_FLASH_TEXT(" us), plate "));
  fw::printInt(sweep_settings_.plate_g);
  say(TC_FLASH_TEXT(" g, range "));
  printSweepPlan();
  fw::newline();

  const uint16_t counts = medianForceCounts();
  say(TC_FLASH_TEXT("load cell "));
  fw::printUint(counts);
  say(TC_FLASH_TEXT(" counts"));
  if (cell_.check(counts) == tc::LoadCellStatus::kImplausible) {
    say(TC_FLASH_TEXT(" (ADC rail: check A0)"));
  } else if (cell_.isTared()) {
    say(TC_FLASH_TEXT(", force "));
    fw::printFixed(forceDecigrams(forceQ4()), 1);
    say(TC_FLASH_TEXT(" g"));
  } else {
    say(TC_FLASH_TEXT(", weight "));
    fw::printInt(cell_.weightGrams(counts));
    say(TC_FLASH_TEXT(" g, not tared"));
  }
  say(TC_FLASH_TEXT("; battery "));
  fw::sayVolts(battery_.millivoltsFromCounts(medianBatteryCounts()));
  fw::newline();
  say(TC_FLASH_TEXT("load cell response: "));
  if (board_settings_.bench.isPresent()) {
    view::printBenchResponse(board_settings_.bench);
    fw::newline();
  } else {
    sayLine(TC_FLASH_TEXT("not identified (dyn cell measures it)"));
  }

  say(TC_FLASH_TEXT("last sweep: "));
  if (!sweep_.valid) {
    sayLine(TC_FLASH_TEXT("none kept"));
  } else {
    say(TC_FLASH_TEXT("motor "));
    fw::printUint(sweep_.slot);
    say(TC_FLASH_TEXT(", "));
    fw::printUint(sweep_.samples);
    say(TC_FLASH_TEXT(" samples, max force "));
    fw::printFixed(sweep_.report.max_force_dg, 1);
    say(TC_FLASH_TEXT(" g, curve 1.."));
    fw::printUint(sweep_.curve.maxGrams());
    sayLine(TC_FLASH_TEXT(" g (store 1, store 2 or store v2 saves it)"));
  }
  fw::printHealth(reader_);
}

// `divider [R1 R2]`: the battery monitor's divider (thrustcal/board_settings.hpp). The last
// sweep's volts came through the old one: it is dropped when the divider changes.
void GatherStoreApp::cmdDividerShow() {
  fw::printDivider(board_settings_);
  fw::newline();
}

void GatherStoreApp::cmdDivider(uint32_t top_ohm, uint32_t bottom_ohm) {
  if (!fw::setDivider(top_ohm, bottom_ohm, board_settings_)) return;
  battery_ = tc::BatteryMonitor(board_settings_.batteryConfig());
  if (sweep_.complete) {
    sweep_.valid = false;
    sweep_.complete = false;
    sayLine(TC_FLASH_TEXT("note: the last sweep was measured with the old divider and is dropped: "
                    "sweep again before store"));
  }
}

}  // namespace gs

// The sweep runner (thesis fig. 6.8: for every PWM step, settle, read force and battery, keep
// them; then the filter functions): the sweep/measure/settle loop and its abort paths. What
// it prints comes from the view (gather_store_view.hpp); what it keeps is the SweepResult
// that `store` decides on (store_decision.hpp).
#include "gather_store_app.hpp"
#include "gather_store_view.hpp"
#include "hal/hal.hpp"

namespace gs {

using fw::say;
using fw::sayLine;

uint16_t GatherStoreApp::plannedSamples() const {
  return static_cast<uint16_t>((sweep_settings_.pwm_max_us - sweep_settings_.pwm_min_us) / sweep_settings_.step_us +
                               1u);
}

void GatherStoreApp::stopMotor() { hal::Esc::writePulse(sweep_settings_.slot, kStopPwmUs); }

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

void GatherStoreApp::printSweepPlan() {
  fw::printUint(sweep_settings_.pwm_min_us);
  say(TC_FLASH_TEXT(".."));
  fw::printUint(sweep_settings_.pwm_max_us);
  say(TC_FLASH_TEXT(" us, step "));
  fw::printUint(sweep_settings_.step_us);
  say(TC_FLASH_TEXT(" us, "));
  printSettle();
}

void GatherStoreApp::printSettle() {
  say(sweep_settings_.settle_auto ? TC_FLASH_TEXT("settle auto (cap ") : TC_FLASH_TEXT("settle "));
  fw::printUint(sweep_settings_.settle_ms);
  say(sweep_settings_.settle_auto ? TC_FLASH_TEXT(" ms)") : TC_FLASH_TEXT(" ms"));
}

bool GatherStoreApp::settleForce(uint16_t& counts) {
  const uint32_t start = hal::Clock::millis();
  tc::SettleAuto settle;
  for (;;) {
    if (!waitOrAbort(kSettleProbeMs)) return false;
    uint32_t centre_us;  // settle auto reads until the force is steady: no instant to correct
    if (!readForceCounts(counts, centre_us)) return false;
    settle = tc::settleAutoNext(settle, counts);
    if (tc::settleAutoDone(settle, hal::Clock::millis() - start, sweep_settings_.settle_ms)) return true;
  }
}

bool GatherStoreApp::readForceCounts(uint16_t& counts, uint32_t& centre_us) {
  force_median_.reset();
  const uint32_t first_us = hal::Clock::micros();
  for (uint16_t i = 0; i < kForceWindow; ++i) {
    hal::Watchdog::kick();
    if (hal::Uart::available()) {
      abortSweep(SweepEnd::kKey, kKeyUnread);
      return false;
    }
    force_median_.push(hal::Adc::readCounts(hal::kAdcLoadCell));
  }
  // The readings' centre, taken before the median's sort (a few ms at the window's end, which
  // would move the instant a lag-corrected sweep reads at: sweep_lag.hpp).
  centre_us = first_us + (hal::Clock::micros() - first_us) / 2u;
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
  say(TC_FLASH_TEXT("# aborted: "));
  switch (why) {
    case SweepEnd::kKey:
      say(TC_FLASH_TEXT("key pressed"));
      break;
    case SweepEnd::kOverload:
      say(TC_FLASH_TEXT("load cell overload, force "));
      fw::printInt(static_cast<int16_t>(value));
      say(TC_FLASH_TEXT(" g (limit "));
      fw::printInt(cell_.config().overload_g);
      say(TC_FLASH_TEXT(" g): lower range MAX"));
      break;
    case SweepEnd::kImplausible:
      say(TC_FLASH_TEXT("load cell reads "));
      fw::printUint(value);
      say(TC_FLASH_TEXT(" counts (ADC rail): check the amplifier and the wire to A0"));
      break;
    case SweepEnd::kBattery:
      say(TC_FLASH_TEXT("battery reads "));
      fw::sayVolts(value);
      say(TC_FLASH_TEXT(", outside "));
      fw::sayVolts(battery_.config().min_sane_mv);
      say(TC_FLASH_TEXT(".."));
      fw::sayVolts(battery_.config().max_sane_mv);
      say(TC_FLASH_TEXT(": check the pack and the divider on A1"));
      break;
    case SweepEnd::kDone:
      break;
  }
  sayLine(TC_FLASH_TEXT("; motor stopped (1000 us), nothing kept: type sweep to start again"));
}

void GatherStoreApp::cmdSweep() {
  if (!cell_.isTared()) {
    sayLine(TC_FLASH_TEXT("error: a sweep needs a tare first: with the motor mounted and stopped, "
                    "type tare (or cal W)"));
    return;
  }
  const uint16_t planned = plannedSamples();
  if (planned > kMaxSweepSamples) {  // range and step refuse this already; kept as a guard
    sayLine(TC_FLASH_TEXT("error: too many steps for the sample buffer: use a larger step"));
    return;
  }
  const uint8_t slot = sweep_settings_.slot;
  sweep_.valid = false;
  sweep_.complete = false;
  if (!swallowLineFeed()) return;
  scratch_.startBuilder();
  sag_builder_.reset(sweep_settings_.pwm_min_us);
  fitter_.reset();

  say(TC_FLASH_TEXT("# sweep motor "));
  fw::printUint(slot);
  say(TC_FLASH_TEXT(": "));
  printSweepPlan();
  say(TC_FLASH_TEXT(", "));
  fw::printUint(planned);
  sayLine(TC_FLASH_TEXT(" steps; any key aborts"));
  if (planned > kMaxV2Samples) {
    say(TC_FLASH_TEXT("# note: model v2 keeps at most "));
    fw::printUint(kMaxV2Samples);
    sayLine(TC_FLASH_TEXT(" steps: store v2 will refuse this sweep (store 1 and store 2 work)"));
  }

  const uint32_t since_arm = hal::Clock::millis() - armed_at_ms_;
  if (since_arm < kArmMs) {
    sayLine(TC_FLASH_TEXT("# arming the ESC (1000 us)"));
    if (!waitOrAbort(static_cast<uint16_t>(kArmMs - since_arm))) return;
  }

  startLagCorrection(slot);
  sayLine(TC_FLASH_TEXT("pwm_us,force_g,vbat_v,t_s,motor,dir"));
  const uint32_t start_ms = hal::Clock::millis();
  const uint32_t start_us = hal::Clock::micros();
  pending_.pwm_us = 0;
  uint16_t pwm = sweep_settings_.pwm_min_us;
  int16_t max_force_dg = 0;
  for (uint16_t done = 1; done <= planned;
       ++done, pwm = static_cast<uint16_t>(pwm + sweep_settings_.step_us)) {
    int16_t force_dg;
    uint16_t vbat_mv;
    if (!measureStep(pwm, start_us, force_dg, vbat_mv)) return;  // aborted, motor already stopped
    keepSample({pwm, force_dg, vbat_mv});
    if (force_dg > max_force_dg) max_force_dg = force_dg;
    view::printCsvRow(pwm, force_dg, vbat_mv, hal::Clock::millis() - start_ms, slot);
    if (done % kProgressEvery == 0 && done != planned) view::sayProgress(done, planned, max_force_dg);
  }
  stopMotor();
  last_end_ = SweepEnd::kDone;
  // The sweep's end is work, not a wait: each stage kicks the watchdog when it is done (without
  // these kicks the end of the largest sweep ran 61 ms between two kicks, 3 ms short of the
  // watchdog's 64: tests/hil_safety, WatchdogHeadroom).
  keepPendingSample(start_us);
  hal::Watchdog::kick();
  tc::SweepPointV2 last;
  if (sweep_.lag_corrected && lag_.finish(last)) addToBuilders(last);
  hal::Watchdog::kick();
  finishSweep(slot, hal::Clock::millis() - start_ms);
  if (sweep_.lag_corrected) view::sayLagCorrected(lag_.largestCorrectionDg());
}

void GatherStoreApp::startLagCorrection(uint8_t slot) {
  sweep_.lag_corrected = false;
  if (sweep_settings_.settle_auto || !board_settings_.bench.isPresent()) return;
  if (tc::readModelV2<hal::Eeprom>(slot, model_, board_settings_.recordLimits()).status != tc::DecodeStatus::kOk ||
      !model_.dynamics.isPresent())
    return;
  lag_dynamics_ = model_.dynamics;
  lag_.start(lag_dynamics_, board_settings_.bench);
  sweep_.lag_corrected = true;
  sayLine(TC_FLASH_TEXT("# readings corrected for the lag: the motor's stored dynamics and the load cell's response"));
}

void GatherStoreApp::addToBuilders(const tc::SweepPointV2& p) {
  scratch_.builder().add(p.pwm_us, p.force_dg);
  sag_builder_.add(p.pwm_us, p.vbat_mv);
  fitter_.add(p.pwm_us, p.force_dg, p.vbat_mv);  // false once full: store v2 then refuses the sweep
}

void GatherStoreApp::keepSample(const tc::SweepPointV2& raw) {
  if (!sweep_.lag_corrected) {
    addToBuilders(raw);
    return;
  }
  pending_ = raw;
}

void GatherStoreApp::keepPendingSample(uint32_t start_us) {
  if (pending_.pwm_us == 0) return;
  tc::SweepPointV2 before;
  const float edge_s = static_cast<float>(step_edge_us_ - start_us) * 1e-6f;
  const float read_s = static_cast<float>(step_read_us_ - start_us) * 1e-6f;
  if (lag_.push(edge_s, read_s, pending_, before)) addToBuilders(before);
  pending_.pwm_us = 0;
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

bool GatherStoreApp::measureStep(uint16_t pwm_us, uint32_t start_us, int16_t& force_dg, uint16_t& vbat_mv) {
  hal::Esc::writePulse(sweep_settings_.slot, pwm_us);
  const uint32_t written_us = hal::Clock::micros();
  keepPendingSample(start_us);  // the step before's correction (none with settle auto), while this one settles
  step_edge_us_ = written_us + escEdgeAfterWriteUs(pwm_us);
  uint16_t force_counts;
  if (sweep_settings_.settle_auto) {
    if (!settleForce(force_counts)) return false;
  } else {
    const uint32_t busy_ms = (hal::Clock::micros() - written_us) / 1000u;  // whole ms: 0 without a correction
    const uint16_t settle_ms = sweep_settings_.settle_ms;
    if (!waitOrAbort(busy_ms < settle_ms ? static_cast<uint16_t>(settle_ms - busy_ms) : 0)) return false;
    if (!readForceCounts(force_counts, step_read_us_)) return false;
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
  force_dg = forceDecigrams(force_q4);
  return true;
}

// Filter functions (fig. 6.9 and G.2): sag offsets and start voltage, then the force curve;
// then the summary lines.

// Filter functions (fig. 6.9 and G.2): sag offsets and start voltage, then the force curve;
// then the summary lines.
void GatherStoreApp::finishSweep(uint8_t slot, uint32_t elapsed_ms) {
  uint16_t start_mv = 0;
  sweep_.sag = tc::SagTable();
  sag_builder_.build(sweep_.sag, start_mv);  // bin 0 holds the first step: cannot fail
  hal::Watchdog::kick();
  sweep_.curve.start_mv = start_mv;
  sweep_.samples = scratch_.builder().size();
  sweep_.report = scratch_.builder().build(sweep_.curve);
  hal::Watchdog::kick();
  sweep_.slot = slot;
  sweep_.complete = true;
  sweep_.valid = sweep_.report.status == tc::BuildStatus::kOk;
  view::saySweepSummary(sweep_, elapsed_ms);
}

}  // namespace gs

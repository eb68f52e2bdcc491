// dyn and dyn cell (issue 26): each motor's speed lag measured on the bench, and once per bench
// the load cell's own response, both from step logs recorded at the ADC's full rate
// (docs/gather_store.md, "Dynamics"; the fits: thrustcal/dynamics_fit.hpp).
//
// A step log is kDynLogBlocks blocks of tc::kDynBlockConversions load-cell conversions and one
// battery conversion, back to back, nothing skipped. dyn writes the new pulse between two blocks
// and notes when the ESC takes it: at the falling edge of the next frame's pulse (the pulse
// registers are double-buffered), i.e. the rest of this frame plus the new width. Every block
// kicks the watchdog and checks the UART (any key aborts: motor to 1000 us first), the rails and
// the overload, as a sweep does.
#include "gather_store_app.hpp"
#include "gather_store_view.hpp"
#include "hal/hal.hpp"
#include "thrustcal/eeprom_store.hpp"
#include "thrustcal/model_v2.hpp"

namespace gs {

using fw::say;
using fw::sayLine;

namespace {

constexpr uint8_t kDynPoints = 5;                // operating points of a session
constexpr uint16_t kDynFirstSettleMs = 3000;     // from a standing motor to the first point (and the
                                                 // pack's polarisation after it)
constexpr uint16_t kDynSettleMs = 700;           // from one point's lower level to the next
constexpr uint16_t kCellQuietBlocks = 100;       // dyn cell: the level and noise before the step
constexpr uint16_t kCellTimeoutMs = 20000;       // dyn cell: waiting for the weight to move
constexpr uint16_t kCellStillMs = 2000;          // dyn cell: the motor stopped before it listens
constexpr int16_t kCellMinStepDg = 20;           // a move of 2 g (or 8x the noise) is the step
constexpr uint8_t kFitStride = 2;                // blocks averaged per fit sample

void kickWatchdog() { hal::Watchdog::kick(); }

uint32_t framePeriodUs() {
  const uint16_t hz = hal::Esc::frameRateHz();
  return hz ? 1000000ul / hz : 20000ul;
}

// A pulse written now reaches the ESC at the falling edge of the next frame's pulse (the
// compare registers are double-buffered), unless this frame's pulse is still high or the frame
// is about to end: then when it takes effect depends on the timer's buffering, so a step waits
// for the next block (about 2 ms) instead. True: writing now is unambiguous.
bool mayWritePulseNow(uint16_t pulse_now_us) {
  const uint32_t in_frame = hal::Esc::frameTimeUs();
  return in_frame > pulse_now_us + 100u && in_frame + 200u < framePeriodUs();
}


}  // namespace

uint16_t escEdgeAfterWriteUs(uint16_t pwm_us) {
  return static_cast<uint16_t>(framePeriodUs() - hal::Esc::frameTimeUs() + pwm_us);
}

namespace {

// Rotates a[0..n) left by k: the oldest block of a ring first.
template <class T>
void rotateLeft(T* a, uint16_t n, uint16_t k) {
  auto reverse = [](T* p, uint16_t len) {
    for (uint16_t i = 0; i < len / 2; ++i) {
      const T t = p[i];
      p[i] = p[len - 1 - i];
      p[len - 1 - i] = t;
    }
  };
  reverse(a, k);
  reverse(a + k, static_cast<uint16_t>(n - k));
  reverse(a, n);
}

}  // namespace

bool GatherStoreApp::readDynBlock(uint16_t& sum_q4, uint16_t& vbat_counts) {
  sum_q4 = 0;
  for (uint8_t i = 0; i < tc::kDynBlockConversions; ++i) sum_q4 = static_cast<uint16_t>(sum_q4 + hal::Adc::readCounts(hal::kAdcLoadCell));
  vbat_counts = hal::Adc::readCounts(hal::kAdcBattery);
  hal::Watchdog::kick();
  if (hal::Uart::available()) {
    abortSweep(SweepEnd::kKey, kKeyUnread);
    return false;
  }
  const uint16_t counts = static_cast<uint16_t>((sum_q4 + 8u) >> 4);
  const tc::LoadCellStatus status = cell_.check(counts);
  if (status == tc::LoadCellStatus::kImplausible) {
    abortSweep(SweepEnd::kImplausible, counts);
    return false;
  }
  if (status == tc::LoadCellStatus::kOverload) {
    abortSweep(SweepEnd::kOverload, static_cast<uint16_t>(cell_.forceGrams(counts)));
    return false;
  }
  return true;
}

bool GatherStoreApp::storeDynBlock(DynLog& log, uint16_t b, uint16_t sum_q4, uint16_t vbat_counts,
                                   uint16_t& vbat_sum) {
  log.force_dg[b] = forceDecigrams(sum_q4);
  vbat_sum = static_cast<uint16_t>(vbat_sum + vbat_counts);
  if ((b + 1u) % tc::kDynBlocksPerVbat != 0) return true;
  const uint16_t mv = battery_.millivoltsFromCounts(static_cast<uint16_t>((vbat_sum + 2u) / tc::kDynBlocksPerVbat));
  vbat_sum = 0;
  if (!battery_.isSane(mv)) {
    abortSweep(SweepEnd::kBattery, mv);
    return false;
  }
  log.vbat_mv[b / tc::kDynBlocksPerVbat] = mv;
  return true;
}

bool GatherStoreApp::recordStep(DynLog& log, uint16_t to_us, DynRecording& rec) {
  rec.from_us = hal::Esc::pulseUs(sweep_settings_.slot);
  rec.to_us = to_us;
  uint16_t vbat_sum = 0;
  rec.start_us = hal::Clock::micros();
  for (uint16_t b = 0; b < kDynLogBlocks; ++b) {
    if (b >= kDynPreBlocks && rec.step_block == 0 && mayWritePulseNow(rec.from_us)) {
      hal::Esc::writePulse(sweep_settings_.slot, to_us);
      rec.edge_after_us = escEdgeAfterWriteUs(to_us);
      rec.step_block = b;
    }
    uint16_t sum_q4, vbat_counts;
    if (!readDynBlock(sum_q4, vbat_counts) || !storeDynBlock(log, b, sum_q4, vbat_counts, vbat_sum)) return false;
  }
  rec.end_us = hal::Clock::micros();
  rec.edge_us = rec.start_us + static_cast<uint32_t>(rec.stepS() * 1e6f);
  if (rec.step_block == 0) {  // no safe moment in 330 blocks: cannot happen with frames <= 20 ms
    stopMotor();
    sayLine(TC_FLASH_TEXT("error: the ESC frame never left room to write the step's pulse; motor stopped"));
    return false;
  }
  return true;
}

// The ring holds the last kDynLogBlocks blocks; the step is the first block that leaves the
// quiet level by more than the threshold, 3 blocks running; the log ends with it 60 blocks in.
bool GatherStoreApp::recordCellStep(DynLog& log, DynRecording& rec) {
  constexpr uint16_t kBeforeTrigger = 2 * kDynPreBlocks;
  int32_t level_sum = 0, dev_sum = 0;
  int16_t level = 0, threshold = kCellMinStepDg;
  uint8_t beyond = 0;
  uint16_t after = 0, vbat_sum = 0;
  bool triggered = false;
  const uint32_t start_ms = hal::Clock::millis();
  const uint32_t first_us = hal::Clock::micros();
  uint32_t blocks = 0;
  for (;; ++blocks) {
    const uint16_t b = static_cast<uint16_t>(blocks % kDynLogBlocks);
    uint16_t sum_q4, vbat_counts;
    if (!readDynBlock(sum_q4, vbat_counts) || !storeDynBlock(log, b, sum_q4, vbat_counts, vbat_sum)) return false;
    const int16_t x = log.force_dg[b];
    if (blocks < kCellQuietBlocks) {  // the level, then the noise about it
      level_sum += x;
      if (blocks + 1 == kCellQuietBlocks / 2) level = static_cast<int16_t>(level_sum / (kCellQuietBlocks / 2));
      if (blocks >= kCellQuietBlocks / 2) dev_sum += x > level ? x - level : level - x;
      if (blocks + 1 == kCellQuietBlocks) {
        const int32_t eight_mad = 8 * dev_sum / (kCellQuietBlocks / 2);
        if (eight_mad > threshold) threshold = static_cast<int16_t>(eight_mad);
      }
      continue;
    }
    if (triggered) {  // ends on a whole battery group, so the ring's groups stay whole
      if (++after + kBeforeTrigger >= kDynLogBlocks && (b + 1u) % tc::kDynBlocksPerVbat == 0) break;
      continue;
    }
    const int16_t dev = x > level ? static_cast<int16_t>(x - level) : static_cast<int16_t>(level - x);
    beyond = dev > threshold ? static_cast<uint8_t>(beyond + 1) : 0;
    triggered = beyond >= 3;
    if (!triggered && hal::Clock::millis() - start_ms > kCellTimeoutMs) {
      sayLine(TC_FLASH_TEXT("error: no weight step in 20 s: hang a weight (5 g or more) on the plate, type dyn "
                            "cell, then lift it off at once; nothing changed"));
      return false;
    }
  }
  rec.end_us = hal::Clock::micros();
  // The ring's oldest block is the one after the last written: rotate it to the front. Its
  // timing: every block has the same length, and the ring's kDynLogBlocks end at end_us.
  const uint32_t block_us = (rec.end_us - first_us) / (blocks + 1u);
  rec.start_us = rec.end_us - block_us * kDynLogBlocks;
  const uint16_t oldest = static_cast<uint16_t>((blocks + 1) % kDynLogBlocks);
  rotateLeft(log.force_dg, kDynLogBlocks, oldest);
  rotateLeft(log.vbat_mv, kDynLogBlocks / tc::kDynBlocksPerVbat, static_cast<uint16_t>(oldest / tc::kDynBlocksPerVbat));
  rec.edge_us = 0;
  return true;
}

tc::StepLog GatherStoreApp::stepLog(const DynLog& log, const DynRecording& rec) const {
  tc::StepLog l;
  l.force_dg = log.force_dg;
  l.blocks = kDynLogBlocks;
  l.block_s = rec.blockS();
  l.step_s = rec.stepS();
  l.vbat_mv = log.vbat_mv;
  l.from_us = rec.from_us;
  l.to_us = rec.to_us;
  l.start_us = static_cast<float>(model_.start_q4_us) * (1.0f / 16.0f);
  l.yield = kickWatchdog;
  return l;
}

void GatherStoreApp::cmdDynCell() {
  if (!cell_.isTared()) {
    sayLine(TC_FLASH_TEXT("error: dyn cell needs a tare first: with the motor mounted and stopped, type tare "
                          "(or cal W)"));
    return;
  }
  stopMotor();
  // A propeller still running down (after a sweep or dyn) would be taken for the step.
  sayLine(TC_FLASH_TEXT("# dyn cell: keep the bench still for 2 s; any key aborts"));
  if (!waitOrAbort(kCellStillMs)) return;
  sayLine(TC_FLASH_TEXT("# dyn cell: now lift the weight off the plate at once (or put one on), within 20 s"));
  DynLog& log = scratch_.startDynLog();  // the last sweep's curve and samples live elsewhere
  DynRecording rec;
  if (!recordCellStep(log, rec)) return;
  view::sayDynHeader();
  view::printDynRows(log, rec, rec.start_us, sweep_settings_.slot, 0);
  const tc::BenchStepFit fit = tc::fitBenchStep(stepLog(log, rec));
  view::sayCellFit(fit);
  if (!fit.ok()) return;
  tc::BoardSettings wanted = board_settings_;
  wanted.bench = fit.response();
  const tc::SettingsWrite w = tc::storeSettings<hal::Eeprom>(wanted);
  if (w.status == tc::SettingsWriteStatus::kWritten || w.status == tc::SettingsWriteStatus::kUnchanged)
    board_settings_ = wanted;
  view::sayCellStored(wanted.bench, w);
}

void GatherStoreApp::cmdDyn() {
  const uint8_t slot = sweep_settings_.slot;
  const tc::RecordLimits limits = board_settings_.recordLimits();
  if (!view::dynMayRun(cell_.isTared(), board_settings_.bench,
                       tc::readModelV2<hal::Eeprom>(slot, model_, limits).status, slot))
    return;
  // The operating points: 20..80 % of the model's force, each stepped from 0.9 F to 1.1 F and back.
  tc::BusVoltageFilter bus;
  bus.reset(battery_.millivoltsFromCounts(medianBatteryCounts()));
  uint16_t lo_us[kDynPoints], hi_us[kDynPoints];
  for (uint8_t i = 0; i < kDynPoints; ++i) {
    const uint32_t f_dg = static_cast<uint32_t>(model_.maxForceDg()) * (5u + 15u * (i + 1u)) / 100u;
    lo_us[i] = tc::forceToPwmV2(model_, static_cast<uint16_t>(f_dg * 9u / 10u), bus).pwm_us;
    hi_us[i] = tc::forceToPwmV2(model_, static_cast<uint16_t>(f_dg * 11u / 10u), bus).pwm_us;
    if (hi_us[i] < lo_us[i] + 4u) hi_us[i] = static_cast<uint16_t>(lo_us[i] + 4u);
  }
  view::sayDynPlan(slot, model_.maxForceDg(), board_settings_.bench, lo_us[0], hi_us[kDynPoints - 1]);
  const uint32_t since_arm = hal::Clock::millis() - armed_at_ms_;
  if (since_arm < kArmMs && !waitOrAbort(static_cast<uint16_t>(kArmMs - since_arm))) return;
  view::sayDynHeader();
  const uint32_t session_us = hal::Clock::micros();
  tc::DynamicsLawFit law;
  for (uint8_t i = 0; i < kDynPoints; ++i) {
    hal::Esc::writePulse(slot, lo_us[i]);
    if (!waitOrAbort(i == 0 ? kDynFirstSettleMs : kDynSettleMs)) return;
    tc::MotorStepFit up, down;
    if (!dynStep(lo_us[i], hi_us[i], session_us, up) || !dynStep(hi_us[i], lo_us[i], session_us, down)) return;
    if (up.ok() && down.ok())
      law.add(0.25f * (up.from_g + up.to_g + down.from_g + down.to_g), up.tau_s, down.tau_s);
  }
  stopMotor();
  const uint32_t session_ms = (hal::Clock::micros() - session_us) / 1000u;
  tc::MotorDynamics d;
  hal::Watchdog::kick();  // the last step's fit and lines took most of a time-out
  if (law.size() < 2 || !law.build(d)) {
    view::sayDynFailed(slot, law.size());
    return;
  }
  model_.dynamics = d;
  hal::Watchdog::kick();  // the store reads and checks the slot's copies and the host copies
  const tc::StoreReport report = tc::storeModelV2<hal::Eeprom>(slot, model_, limits);
  view::sayDynStored(slot, d, session_ms, report);
}

bool GatherStoreApp::dynStep(uint16_t from_us, uint16_t to_us, uint32_t session_us, tc::MotorStepFit& fit) {
  DynLog& log = scratch_.startDynLog();
  DynRecording rec;
  if (!recordStep(log, to_us, rec)) return false;
  const int8_t dir = to_us > from_us ? 1 : -1;
  view::sayDynStep(dir, rec, session_us, log.vbat_mv[0]);
  view::printDynRows(log, rec, session_us, sweep_settings_.slot, dir);
  fit = tc::fitMotorStep(stepLog(log, rec), board_settings_.bench, kFitStride);
  view::sayDynFit(dir, rec, fit);
  return true;
}

}  // namespace gs

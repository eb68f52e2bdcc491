// The force API (force_actuators.hpp): loading the four slots once, and the ESC frame.
#include "force_actuators.hpp"

#include "hal/hal.hpp"

namespace fw {

namespace {

// A thesis motor's sag offset (thesis fig. 6.9) for the pulse it was last sent, looked up in its
// model's table only when that pulse changed: after each write (prepareNextFrame) and, for a
// pulse set without one, in the frame (flyMotor).
inline void keepSagOffset(Motor& m, const tc::SagTable& sag) {
  if (m.sag_pwm_us == m.pwm_us) return;
  m.sag_offset_mv = sag.offsetFor(m.pwm_us);
  m.sag_pwm_us = m.pwm_us;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Battery

void BatteryInput::sample(bool frame_reading) {
  static_assert(kSamplesPerFrame == 4, "middleTwoCounts takes four readings");
  uint16_t counts[kSamplesPerFrame];
  for (uint8_t k = 0; k < kSamplesPerFrame; ++k) {
    counts[k] = hal::Adc::readCounts(hal::kAdcBattery);
    counts_.push(counts[k]);
  }
  median_mv_ = monitor_.millivoltsFromCounts(counts_.median());
  if (!frame_reading) return;
  // Mean of the middle two through the thesis map() at half-count resolution: equal readings
  // give exactly map(reading).
  frame_mv_ = monitor_.millivoltsFromTwoCounts(middleTwoCounts(counts, monitor_.config().adc_max_counts));
}

// ---------------------------------------------------------------------------------------------
// Loading (start-up, and after a divider change)

void ForceActuators::loadSettings() {
  tc::readSettings<hal::Eeprom>(board_settings_);
  battery_.configure(board_settings_);
}

uint8_t ForceActuators::loadSlots(SlotReport report) {
  for (uint8_t i = 0; i < kMotors; ++i) loadSlot(i, report);
  assignLanes();
  placeCursors(start_dg_);
  if (shaping_ && !configureShaping()) clearShaping();  // the new records' dynamics
  return armableCount();
}

void ForceActuators::loadSlot(uint8_t index, SlotReport report) {
  hal::Watchdog::kick();  // decoding a slot reads and checks up to 1 KB of EEPROM
  Motor& m = motors_[index];
  // The loader decodes into these (start-up only, on the stack); the slot keeps the compact
  // form the frame flies (the thesis curves' steps stay in the EEPROM).
  tc::ModelV2 v2;
  tc::MotorCalibration v1;
  const tc::SlotLoad load = tc::loadSlot<hal::Eeprom>(index, v2, v1, board_settings_.recordLimits());
  m.layout = load.layout;
  // Neither layout recognized: copy A's status is that of the version byte at the slot start
  // (erased or unknown), which both layouts share; the loader's "most telling copy" would
  // report stale v1 bytes at copy B's offset instead.
  m.record = load.layout == tc::SlotLayout::kNone ? load.v2.copy_status[0] : load.status;
  m.v2_copy = load.v2.copy;
  m.v2_copy_status[0] = load.v2.copy_status[0];
  m.v2_copy_status[1] = load.v2.copy_status[1];
  m.why = load.why;
  m.source = index;
  m.sag_pwm_us = 0;  // the offset kept was the old model's
  m.model.clear();
  m.dynamics.clear();
  m.shaper.disable();
  if (m.record == tc::DecodeStatus::kOk) {
    const bool loaded = load.layout == tc::SlotLayout::kModelV2 ? m.model.setV2(v2)
                                                                : m.model.setV1<hal::Eeprom>(v1, index);
    if (!loaded) {  // the EEPROM changed under the loader: never flown
      m.record = tc::DecodeStatus::kBadContent;
      m.model.clear();
    } else if (load.layout == tc::SlotLayout::kModelV2) {
      m.dynamics = v2.dynamics;
    }
  }
  m.force_dg = 0;
  m.shaped_dg = 0;
  m.pwm_us = tc::kStopPwmUs;
  m.flags = m.isArmable() ? tc::kStopped : tc::kNotCalibrated;
  if (report != nullptr) report(index, m, v2, v1);
}

// A lane per motor whose model is v2, in motor order, flying its source's model.
void ForceActuators::assignLanes() {
  v2_.count = 0;
  for (uint8_t i = 0; i < kMotors; ++i) {
    Motor& m = motors_[i];
    const Motor& source = motors_[m.source];
    m.lane = kNoLane;
    if (source.fliesV2()) {
      m.lane = v2_.count++;
      v2_.lane[m.lane].setModel(&source.model.v2());
    }
  }
}

bool ForceActuators::setModelSource(uint8_t index, uint8_t slot) {
  if (index >= kMotors || slot >= kMotors || isRunning()) return false;
  if (slot != index && !motors_[slot].isArmable()) return false;
  motors_[index].source = slot;
  motors_[index].sag_pwm_us = 0;  // its sag offset comes from the new model's table
  assignLanes();
  prepareNextFrame();  // now, not in the first frame's computation
  if (shaping_ && !configureShaping()) clearShaping();  // the dynamics follow the model
  return true;
}

uint16_t ForceActuators::maxForceDg(uint8_t index) const {
  const Motor& source = motors_[motors_[index].source];
  if (!source.isArmable()) return 0;
  if (source.model.holdsV2()) return source.model.v2().max_force_dg;
  const tc::ThesisRun& thesis = source.model.v1();
  const uint16_t first = thesis.first.maxGrams();
  const uint16_t second = thesis.hasSecondCurve() ? thesis.second.maxGrams() : first;
  return static_cast<uint16_t>(10u * (second < first ? second : first));
}

void ForceActuators::restartFilters() {
  const uint8_t shift = v2_.bus.shift;
  v2_.bus = tc::BusVoltageFilter();
  v2_.bus.shift = shift;
  v2_.sag = tc::BusSagFilter();
}

// ---------------------------------------------------------------------------------------------
// Commands

uint8_t ForceActuators::armableCount() const {
  uint8_t n = 0;
  for (uint8_t i = 0; i < kMotors; ++i) n += motors_[i].isArmable() ? 1 : 0;
  return n;
}

bool ForceActuators::isRunning() const {
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (motors_[i].force_dg > 0) return true;
  }
  return false;
}

void ForceActuators::setForceDg(uint8_t index, uint16_t force_dg) {
  if (isArmable(index)) motors_[index].force_dg = force_dg < kMaxForceDg ? force_dg : kMaxForceDg;
}

void ForceActuators::stopAll() {
  uint16_t pulses_us[kMotors];
  for (uint8_t i = 0; i < kMotors; ++i) {
    Motor& m = motors_[i];
    m.force_dg = 0;
    m.shaped_dg = 0;
    m.pwm_us = tc::kStopPwmUs;
    m.flags = isArmable(i) ? tc::kStopped : tc::kNotCalibrated;
    pulses_us[i] = tc::kStopPwmUs;
  }
  hal::Esc::writeAll(pulses_us);
  // The next start's first frame then finds the stop pulse's sag offset and each thesis
  // curve's lookup at the force it starts from (prepareNextFrame, placeCursors).
  prepareNextFrame();
  placeCursors(start_dg_);
}

void ForceActuators::setStartForceDg(uint16_t force_dg) {
  start_dg_ = force_dg;
  placeCursors(start_dg_);
}

void ForceActuators::placeCursors(uint16_t force_dg) {
  for (uint8_t i = 0; i < kMotors; ++i) {
    const Motor& m = motors_[i];
    if (m.isArmable() && !m.model.holdsV2()) m.model.v1().placeCursors<hal::Eeprom>(static_cast<uint16_t>(force_dg / 10u));
  }
}

// A new filter constant re-seeds the filter at its value (one division) and rescales the
// motors' seen forces.
void ForceActuators::setFrameRate(uint16_t frame_hz) {
  if (frame_hz != frame_hz_) {
    frame_hz_ = frame_hz;
    if (shaping_ && !configureShaping()) clearShaping();
  }
  const uint8_t shift = filterShiftFor(frame_hz);
  if (shift == v2_.bus.shift) return;
  v2_.bus.shift = shift;
  if (v2_.bus.isValid()) v2_.bus.reset(v2_.bus.mv);
}

// ---------------------------------------------------------------------------------------------
// The ESC frame (thesis fig. 6.9, H.3). Integer only.

void ForceActuators::frame() {
  sampleBattery();
  output();
}

void ForceActuators::sampleBattery() { battery_.sample(v2_.count != 0); }

void ForceActuators::output() {
  computePulses();
  writePulses();
}

void ForceActuators::computePulses() {
  shapeCommands();
  if (v2_.count != 0) flyV2Motors();
  for (uint8_t i = 0; i < kMotors; ++i) flyMotor(motors_[i]);
}

void ForceActuators::writePulses() {
  uint16_t pulses_us[kMotors];
  for (uint8_t i = 0; i < kMotors; ++i) pulses_us[i] = motors_[i].pwm_us;
  hal::Esc::writeAll(pulses_us);  // the four outputs back to back
  prepareNextFrame();
}

// Between frames, after the write, what the next frame's computation (between the IMU read and
// the write) would otherwise do for each thesis motor: the sag offset of the pulse it was just
// sent (flyMotor finds it kept; it still looks it up for a pulse set without a write, stopAll's).
// The same offset, only earlier: the pulses are the same to the bit.
void ForceActuators::prepareNextFrame() {
  if (v2_.count == kMotors) return;  // every motor flies v2: nothing to prepare
  for (uint8_t i = 0; i < kMotors; ++i) {
    Motor& m = motors_[i];
    const Motor& source = motors_[m.source];
    if (m.lane == kNoLane && source.isArmable()) keepSagOffset(m, source.model.v1().sag);
  }
}

// The v2 motors in one pass (tc::V2Frame: the bus filter, the sag prediction, every v2 motor's
// pulse): their commands go into their lanes, this frame's reading into the filter; an insane
// reading is skipped by the filter (it keeps the last good value) and flagged on the results.
void ForceActuators::flyV2Motors() {
  for (uint8_t i = 0; i < kMotors; ++i) {
    const Motor& m = motors_[i];
    if (m.lane != kNoLane) v2_.lane[m.lane].force_dg = m.shaped_dg;
  }
  v2_.fly(battery_.frameMv(), battery_.frameSane() ? 0 : tc::kVoltageInvalid);
}

// One motor's pulse for this frame from its model. The v2 motors' pulses come from their
// lanes (flyV2Motors), with no division on their path.
void ForceActuators::flyMotor(Motor& m) {
  const Motor& source = motors_[m.source];
  if (!source.isArmable()) {
    m.force_dg = 0;
    m.shaped_dg = 0;
    m.pwm_us = tc::kStopPwmUs;
    m.flags = tc::kNotCalibrated;
    m.vbat_mv = battery_.medianMv();
    return;
  }
  if (m.lane != kNoLane) {
    const tc::V2Lane& lane = v2_.lane[m.lane];
    m.pwm_us = lane.pwm_us;
    m.flags = lane.flags;
    m.vbat_mv = v2_.bus.mv;
    return;
  }
  // Thesis fig. 6.9: the reading sags under this motor's load; add the offset of the PWM it
  // was last sent (looked up again only when that pulse changed; after a write
  // prepareNextFrame has done it).
  const tc::ThesisRun& thesis = source.model.v1();
  keepSagOffset(m, thesis.sag);
  m.vbat_mv = tc::BatteryMonitor::withSagOffset(battery_.medianMv(), m.sag_offset_mv);
  static const tc::ForcePwmLimits kLimits;  // the defaults, made once, not on every call
  const tc::ForcePwmResult result = tc::forceToPwmDg<hal::Eeprom>(thesis, m.shaped_dg, m.vbat_mv, kLimits);
  m.pwm_us = result.pwm_us;
  m.flags = result.flags;
}

// ---------------------------------------------------------------------------------------------
// Equal dynamics (thrustcal/dyn_shaper.hpp)

// Each motor's command through its filter (integer; a motor without dynamics, or shaping off:
// as commanded). Every motor's shaped force goes to its model this frame.
// The four filters in one call (tc::DynShaper::stepAll: one register save a frame), each motor's
// largest force as configureShaping found it.
void ForceActuators::shapeCommands() {
  if (!shaping_) {
    for (uint8_t i = 0; i < kMotors; ++i) motors_[i].shaped_dg = motors_[i].force_dg;
    return;
  }
  tc::DynShaper* shapers[kMotors];
  uint16_t force_dg[kMotors];
  uint16_t shaped_dg[kMotors];
  for (uint8_t i = 0; i < kMotors; ++i) {
    shapers[i] = &motors_[i].shaper;
    force_dg[i] = motors_[i].force_dg;
  }
  tc::DynShaper::stepAll(shapers, force_dg, shaping_max_dg_, shaped_dg, kMotors, reference_table_);
  for (uint8_t i = 0; i < kMotors; ++i) motors_[i].shaped_dg = shaped_dg[i];
}

// The reference over the heaviest force any motor flies, each motor's filter against it; the
// dynamics are those of the slot whose model the motor flies (fly's generic mode flies one
// slot's model and dynamics for all four, as an uncalibrated aircraft would assume).
bool ForceActuators::configureShaping() {
  const tc::MotorDynamics* laws[kMotors];
  uint16_t max_dg = 0;
  for (uint8_t i = 0; i < kMotors; ++i) {
    const Motor& source = motors_[motors_[i].source];
    laws[i] = isArmable(i) ? &source.dynamics : nullptr;
    const uint16_t most = maxForceDg(i);
    shaping_max_dg_[i] = most;  // the model's, fixed until the next configureShaping
    if (most > max_dg) max_dg = most;
  }
  // Float tables (expf, sqrtf per bin): the watchdog is kicked between the parts, each well
  // inside its time-out (fly reset without these kicks in simavr).
  hal::Watchdog::kick();
  if (!tc::buildShaperReference(reference_table_, reference_, laws, kMotors, max_dg, frame_hz_)) return false;
  uint8_t shaped = 0;
  for (uint8_t i = 0; i < kMotors; ++i) {
    hal::Watchdog::kick();
    Motor& m = motors_[i];
    if (laws[i] == nullptr) {
      m.shaper.disable();
      continue;
    }
    m.shaper.configure(*laws[i], reference_table_, frame_hz_, m.force_dg);
    shaped += m.shaper.isActive() ? 1 : 0;
  }
  return shaped != 0;
}

ForceActuators::Shaping ForceActuators::setShaping(const tc::ShaperReference& reference) {
  if (!reference.isValid()) return Shaping::kBadReference;
  const tc::ShaperReference before = reference_;
  reference_ = reference;
  if (!configureShaping()) {
    reference_ = before;
    if (shaping_ && !configureShaping()) clearShaping();
    return Shaping::kNoDynamics;
  }
  shaping_ = true;
  return Shaping::kOn;
}

void ForceActuators::clearShaping() {
  shaping_ = false;
  for (uint8_t i = 0; i < kMotors; ++i) motors_[i].shaper.disable();
}

uint8_t ForceActuators::shapedMotors() const {
  uint8_t n = 0;
  for (uint8_t i = 0; i < kMotors; ++i) n += (shaping_ && motors_[i].shaper.isActive()) ? 1 : 0;
  return n;
}

}  // namespace fw

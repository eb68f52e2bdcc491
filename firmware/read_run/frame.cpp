// read_run's ESC frame (thesis fig. 6.9, H.3): every frame the battery readings, each motor's
// force command through its model, and the four pulses written at once. Integer only; runs from
// service() (read_run_app.cpp), also inside a blocked UART write.
#include "read_run_app.hpp"

namespace rr {

void ReadRunApp::scheduleFrames(uint32_t now_ms) {
  frames_.restart(now_ms);
  stream_countdown_ = 0;
}

void ReadRunApp::setFrameRate(uint16_t frame_hz) {
  frame_hz_ = frame_hz;
  setFilterShift(frame_hz);
  stream_every_frames_ = static_cast<uint8_t>(frame_hz / kStreamLinesPerSecond);
}

// v1 and status: the thesis median of 101. v2: this frame's four readings (middle two) into
// the frame of the v2 motors (tc::V2Frame: the bus filter, the sag prediction, every v2 motor's
// pulse), every frame while a v2 motor is loaded; an insane reading is skipped by the filter
// (it keeps the last good value) and flagged on the v2 motors' results.
void ReadRunApp::sampleBattery() {
  static_assert(kBatterySamplesPerFrame == 4, "middleTwoCounts takes four readings");
  uint16_t counts[kBatterySamplesPerFrame];
  for (uint8_t k = 0; k < kBatterySamplesPerFrame; ++k) {
    counts[k] = hal::Adc::readCounts(hal::kAdcBattery);
    battery_counts_.push(counts[k]);
  }
  battery_mv_ = monitor_.millivoltsFromCounts(battery_counts_.median());
  if (v2_.count == 0) return;
  // Mean of the middle two through the thesis map() at half-count resolution: equal readings
  // give exactly map(reading).
  const uint16_t frame_mv = monitor_.millivoltsFromTwoCounts(
      middleTwoCounts(counts, monitor_.config().adc_max_counts));
  bus_sample_sane_ = monitor_.isSane(frame_mv);
  v2_.fly(frame_mv, bus_sample_sane_ ? 0 : tc::kVoltageInvalid);
}

// A new filter constant re-seeds the filter at its value (one division) and rescales the
// motors' seen forces.
void ReadRunApp::setFilterShift(uint16_t frame_hz) {
  const uint8_t shift = filterShiftFor(frame_hz);
  if (shift == v2_.bus.shift) return;
  v2_.bus.shift = shift;
  if (v2_.bus.isValid()) v2_.bus.reset(v2_.bus.mv);
}

void ReadRunApp::setForce(uint8_t index, uint16_t force_g) {
  Motor& m = motors_[index];
  m.force_g = force_g;
  if (m.lane != kNoLane) v2_.lane[m.lane].force_dg = static_cast<uint16_t>(force_g * 10u);  // <= 5000
}

// One motor's pulse for this frame from its model. Integer only; the v2 motors' pulses come
// from the frame (sampleBattery), no division on their path.
void ReadRunApp::flyMotor(Motor& m) {
  if (!m.isArmable()) {
    m.force_g = 0;
    m.pwm_us = kStopPwmUs;
    m.flags = tc::kNotCalibrated;
    m.vbat_mv = battery_mv_;
    return;
  }
  if (m.fliesV2()) {
    const tc::V2Lane& lane = v2_.lane[m.lane];
    m.pwm_us = lane.pwm_us;
    m.flags = lane.flags;
    m.vbat_mv = v2_.bus.mv;
    return;
  }
  // Thesis fig. 6.9: the reading sags under this motor's load; add the offset of the PWM it
  // was last sent.
  const tc::ThesisRun& thesis = m.model.v1();
  m.vbat_mv = monitor_.compensatedMillivolts(battery_mv_, m.pwm_us, thesis.sag);
  const tc::ForcePwmResult result = tc::forceToPwm<hal::Eeprom>(thesis, m.force_g, m.vbat_mv);
  m.pwm_us = result.pwm_us;
  m.flags = result.flags;
}

void ReadRunApp::frame(uint32_t now_ms) {
  frames_.advance(now_ms, frame_hz_);

  if (mode_ == Mode::kLiftoff) updateLiftoff(now_ms);
  sampleBattery();
  uint16_t pulses_us[kMotors];
  for (uint8_t i = 0; i < kMotors; ++i) {
    flyMotor(motors_[i]);
    pulses_us[i] = motors_[i].pwm_us;
  }
  hal::Esc::writeAll(pulses_us);  // the four outputs back to back

  note_ms_ = now_ms;
  if (mode_ == Mode::kLiftoff) {
    if (static_cast<int32_t>(now_ms - liftoff_next_progress_ms_) >= 0) {
      liftoff_next_progress_ms_ += kLiftoffProgressMs;
      note_force_g_ = motors_[0].force_g;
      notes_ |= kNoteProgress;
    }
  }
  if (stream_ && mode_ != Mode::kArming) {
    if (stream_countdown_ == 0) {
      notes_ |= kNoteStream;
      stream_countdown_ = stream_every_frames_;
    }
    --stream_countdown_;
  }
}

}  // namespace rr

// Read and Run: see read_run_app.hpp for the flow and the safety rules.
#include "read_run_app.hpp"

#include "eeprom_console.hpp"

namespace rr {

ReadRunApp* ReadRunApp::active_ = nullptr;

namespace {

constexpr uint8_t kMaxTokens = 6;

using fw::say;
using fw::sayCopy;
using fw::sayLine;
using fw::sayVolts;

// Heaviest force both curves reach without saturating.
uint16_t reachableGrams(const tc::MotorCalibration& cal) {
  uint16_t grams = cal.first.maxGrams();
  if (cal.hasSecondCurve() && cal.second.maxGrams() < grams) grams = cal.second.maxGrams();
  return grams;
}

void sayMotor(uint8_t index) {
  say(TC_PSTR("motor "));
  fw::printUint(index);
}

// Why a motor is not armed: the decode status (with the plausibility rule a record broke);
// for a v2 slot both copies' reasons.
void sayRecordStatus(const Motor& m) {
  say(TC_PSTR("not calibrated: "));
  if (m.layout != tc::SlotLayout::kModelV2) {
    fw::printRecordStatus(m.record, m.why);
    return;
  }
  say(TC_PSTR("v2 record, both copies bad ("));
  for (uint8_t copy = 0; copy < 2; ++copy) {
    if (copy) say(TC_PSTR(", "));
    sayCopy(copy);
    say(TC_PSTR(" "));
    hal::Uart::print(tc::decodeStatusText(m.v2_copy_status[copy]));
  }
  say(TC_PSTR(")"));
  if (m.record == tc::DecodeStatus::kBadContent && !m.why.ok()) {
    say(TC_PSTR(": "));
    fw::printRecordStatus(m.record, m.why);
  }
}

// Grams (floor) of a force in decigrams.
uint16_t gramsFromDg(uint16_t force_dg) { return static_cast<uint16_t>(force_dg / 10u); }

// Start-up line of a v1 slot (the thesis record), after "motor N: ok".
void sayV1Summary(const tc::MotorCalibration& cal) {
  say(TC_PSTR(", V1 "));
  sayVolts(cal.first.start_mv);
  say(TC_PSTR(", V2 "));
  if (cal.hasSecondCurve()) {
    sayVolts(cal.second.start_mv);
  } else {
    say(TC_PSTR("none (single curve, no voltage compensation)"));
  }
  say(TC_PSTR(", max "));
  fw::printUint(reachableGrams(cal));
  say(TC_PSTR(" g, model v1 (thesis option 2.1)"));
}

// Start-up line of a v2 slot, after "motor N: ok": start threshold, the force reachable at
// the sweep's resting voltage, the refining sweep's voltage, and a damaged other copy.
void sayV2Summary(const Motor& m, const tc::ModelV2& v2, uint8_t index) {
  say(TC_PSTR(", model v2 (effective voltage), start "));
  fw::printFixed(static_cast<int32_t>((static_cast<uint32_t>(v2.start_q4_us) * 10u + 8u) >> 4), 1);
  say(TC_PSTR(" us, max "));
  fw::printUint(gramsFromDg(tc::headroomDg(v2, v2.rest_mv)));
  say(TC_PSTR(" g at "));
  sayVolts(v2.rest_mv);
  if (v2.second_mv != 0) {
    say(TC_PSTR(", refined at "));
    sayVolts(v2.second_mv);
  }
  if (tc::isSpareCopy(m.v2_copy)) {
    // A store was cut short after its copy in another slot was complete.
    say(TC_PSTR("; flying the copy kept in motor "));
    fw::printUint(tc::spareHost(index, m.v2_copy));
    say(TC_PSTR("'s slot (a store was cut short; the next gather_store store settles it)"));
    return;
  }
  const uint8_t other = static_cast<uint8_t>(m.v2_copy ^ 1u);
  const tc::DecodeStatus other_status = m.v2_copy_status[other];
  if (other_status != tc::DecodeStatus::kOk && other_status != tc::DecodeStatus::kErased) {
    say(TC_PSTR("; warning: "));
    sayCopy(other);
    say(TC_PSTR(" "));
    hal::Uart::print(tc::decodeStatusText(other_status));
    say(TC_PSTR(", flying "));
    sayCopy(m.v2_copy);
    say(TC_PSTR(" - recalibrate to restore the spare copy"));
  }
}

// Mean of the middle two of four readings (one spike either way is ignored), through the
// thesis map() at half-count resolution: equal readings give exactly map(reading).
uint16_t middleTwoMillivolts(const uint16_t* counts, const tc::BatteryMonitor& monitor) {
  const uint16_t adc_max = monitor.config().adc_max_counts;
  uint16_t sum = 0;
  uint16_t lo = 0xFFFF;
  uint16_t hi = 0;
  for (uint8_t k = 0; k < 4; ++k) {
    const uint16_t c = counts[k] < adc_max ? counts[k] : adc_max;
    sum = static_cast<uint16_t>(sum + c);
    if (c < lo) lo = c;
    if (c > hi) hi = c;
  }
  return monitor.millivoltsFromTwoCounts(static_cast<uint16_t>(sum - lo - hi));  // <= 2 * 1023
}

// Flags of one controller result in words, comma separated; "none" when clear.
void sayFlags(uint8_t flags) {
  if (flags == 0) {
    say(TC_PSTR("none"));
    return;
  }
  bool first = true;
  auto word = [&](uint8_t bit, const char* text) {
    if ((flags & bit) == 0) return;
    if (!first) say(TC_PSTR(", "));
    say(text);
    first = false;
  };
  word(tc::kStopped, TC_PSTR("stopped"));
  word(tc::kNotCalibrated, TC_PSTR("not calibrated"));
  word(tc::kSaturated, TC_PSTR("saturated"));
  word(tc::kVoltageInvalid, TC_PSTR("battery voltage invalid"));
  word(tc::kSingleCurve, TC_PSTR("single curve"));
  word(tc::kEqualVoltages, TC_PSTR("equal curve voltages"));
  word(tc::kClamped, TC_PSTR("clamped"));
}

bool parseMs(const char* token, uint16_t& ms) {
  int32_t value = 0;
  if (!fw::parseInt(token, 0, kLiftoffMaxMs, value)) return false;
  ms = static_cast<uint16_t>(value);
  return true;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Start-up

void ReadRunApp::printBanner() {
  fw::newline();
  sayLine(TC_PSTR("read_run: force commands in grams -> ESC pulses (thrustcal, thesis Read and Run)"));
  fw::printResetCause();
  sayLine(TC_PSTR("type help for commands; while motors run send a line at least every 500 ms"));
}

uint8_t ReadRunApp::loadCalibration() {
  uint8_t calibrated = 0;
  v2_.count = 0;
  // The board's divider first: counts -> volts, and the voltages a record may hold.
  tc::readSettings<hal::Eeprom>(settings_);
  monitor_ = tc::BatteryMonitor(settings_.batteryConfig());
  const tc::RecordLimits limits = settings_.recordLimits();
  say(TC_PSTR("battery monitor: "));
  fw::printDivider(settings_);
  fw::newline();
  for (uint8_t i = 0; i < kMotors; ++i) {
    hal::Watchdog::kick();  // decoding a slot reads and checks up to 1 KB of EEPROM
    Motor& m = motors_[i];
    // The loader decodes into these (1.2 KB of stack, start-up only); the slot keeps the
    // compact form the frame flies (the thesis curves' steps stay in the EEPROM).
    tc::ModelV2 v2;
    tc::MotorCalibration v1;
    const tc::SlotLoad load = tc::loadSlot<hal::Eeprom>(i, v2, v1, limits);
    m.layout = load.layout;
    // Neither layout recognized: copy A's status is that of the version byte at the slot
    // start (erased or unknown), which both layouts share; the loader's "most telling copy"
    // would report stale v1 bytes at copy B's offset instead.
    m.record = load.layout == tc::SlotLayout::kNone ? load.v2.copy_status[0] : load.status;
    m.v2_copy = load.v2.copy;
    m.v2_copy_status[0] = load.v2.copy_status[0];
    m.v2_copy_status[1] = load.v2.copy_status[1];
    m.why = load.why;
    m.lane = kNoLane;
    m.model.clear();
    if (m.record == tc::DecodeStatus::kOk) {
      const bool loaded = load.layout == tc::SlotLayout::kModelV2 ? m.model.setV2(v2)
                                                                  : m.model.setV1<hal::Eeprom>(v1, i);
      if (!loaded) {  // the EEPROM changed under the loader: never flown
        m.record = tc::DecodeStatus::kBadContent;
        m.model.clear();
      } else if (m.model.holdsV2()) {
        m.lane = v2_.count++;
        v2_.lane[m.lane].setModel(&m.model.v2());
      }
    }
    setForce(i, 0);
    m.pwm_us = kStopPwmUs;
    m.flags = m.isArmable() ? tc::kStopped : tc::kNotCalibrated;
    sayMotor(i);
    say(TC_PSTR(": "));
    if (m.isArmable()) {
      ++calibrated;
      say(TC_PSTR("ok"));
      if (m.fliesV2()) {
        sayV2Summary(m, v2, i);
      } else {
        sayV1Summary(v1);
      }
    } else {
      sayRecordStatus(m);
      say(TC_PSTR(" - refusing to arm; recalibrate it with gather_store"));
    }
    fw::newline();
  }
  say(TC_PSTR("calibrated motors: "));
  fw::printUint(calibrated);
  sayLine(TC_PSTR(" of 4"));
  if (calibrated == 0) {
    sayLine(TC_PSTR("warning: no motor is calibrated; every ESC stays at 1000 us - calibrate the "
                    "motors with gather_store first"));
  }
  return calibrated;
}

void ReadRunApp::arm() {
  mode_ = Mode::kArming;
  sayLine(TC_PSTR("arming... (every ESC at 1000 us for 2 s)"));
  for (uint8_t i = 0; i < kMotors; ++i) {
    setForce(i, 0);
    motors_[i].pwm_us = kStopPwmUs;
    hal::Esc::writePulse(i, kStopPwmUs);
  }
  frame_hz_ = hal::Esc::frameRateHz();
  if (frame_hz_ < hal::kEscMinFrameHz || frame_hz_ > hal::kEscMaxFrameHz) {
    frame_hz_ = hal::kEscDefaultFrameHz;
  }
  setFilterShift(frame_hz_);
  stream_every_frames_ = static_cast<uint8_t>(frame_hz_ / kStreamLinesPerSecond);
  const uint32_t start_ms = hal::Clock::millis();
  scheduleFrames(start_ms);
  active_ = this;
  hal::Uart::setWaitHook(&ReadRunApp::serviceHook);
  for (;;) {
    const uint32_t now_ms = hal::Clock::millis();
    if (now_ms - start_ms >= kArmMs) break;
    // Forces are 0: every frame writes 1000 us and feeds the battery median.
    service();
    hal::Clock::sleepUntilInterrupt();
  }
  notes_ = 0;
  bool discarded = false;
  while (hal::Uart::read() != hal::Uart::kNothing) discarded = true;
  line_.clear();
  mode_ = Mode::kReady;
  last_line_ms_ = hal::Clock::millis();
  sayLine(TC_PSTR("armed"));
  if (discarded) {
    sayLine(TC_PSTR("note: input received while arming was ignored; send commands after \"armed\""));
  }
  prompt();
}

// ---------------------------------------------------------------------------------------------
// Main loop

bool ReadRunApp::isRunning() const {
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (motors_[i].force_g > 0) return true;
  }
  return false;
}

// One pass: at most one input event (bounded bytes), the time-critical part (so a command
// takes effect in the frame that follows it), then what the time-critical part had to say.
// Whatever blocks (a long reply waiting for room in the transmit ring) runs service() from the
// UART wait hook, so frames, the battery filter, the failsafe and the lift-off link timeout
// stay on time.
void ReadRunApp::runOnce() {
  handleInput();
  service();
  printNotes();
}

void ReadRunApp::serviceHook() {
  if (active_ != nullptr) active_->service();
}

void ReadRunApp::service() {
  if (in_service_) return;
  in_service_ = true;
  hal::Watchdog::kick();  // the loop (or a wait inside it) came round
  const uint32_t now_ms = hal::Clock::millis();
  if (frameDue(now_ms)) frame(now_ms);
  checkFailsafe(now_ms);
  in_service_ = false;
}

void ReadRunApp::handleInput() {
  const uint32_t now_ms = hal::Clock::millis();
  if (mode_ == Mode::kLiftoff) {
    // Lift-off: a line end (an empty line) keeps it alive; any other byte aborts it, and the
    // rest of that byte's line is discarded.
    for (uint8_t n = 0; n < kRxBytesPerPass && hal::Uart::available(); ++n) {
      const int16_t item = hal::Uart::read();
      if (item == '\r' || item == '\n') {
        last_line_ms_ = now_ms;
        continue;
      }
      if (item == hal::Uart::kNothing) break;
      abortLiftoff(item);
      return;
    }
    return;
  }
  if (mode_ != Mode::kReady) return;
  const fw::LineEvent event = line_.poll(kRxBytesPerPass);
  if (event == fw::LineEvent::kRejected) {  // its error line is printed; not a keep-alive
    prompt();
    return;
  }
  if (event != fw::LineEvent::kLine) return;
  // The keep-alive: a complete, intact line (with strict on: one with a valid checksum).
  if (!line_.strict() || line_.checked()) last_line_ms_ = now_ms;
  char line[fw::kLineMax + 1];
  const char* src = line_.line();
  uint8_t n = 0;
  while (n < fw::kLineMax && src[n] != '\0') {
    line[n] = src[n];
    ++n;
  }
  line[n] = '\0';
  handleLine(line);
}

// While a motor runs (lift-off included), no keep-alive for kFailsafeMs stops every motor.
void ReadRunApp::checkFailsafe(uint32_t now_ms) {
  if (mode_ == Mode::kLiftoff) {
    if (now_ms - last_line_ms_ < kFailsafeMs) return;
    stopAll();
    mode_ = Mode::kReady;
    ++failsafe_trips_;
    notes_ |= kNoteLinkLost;
    return;
  }
  if (mode_ != Mode::kReady || !isRunning()) return;
  if (now_ms - last_line_ms_ < kFailsafeMs) return;
  stopAll();
  ++failsafe_trips_;
  notes_ |= kNoteFailsafe;
}

// What service() had to say, in the order it happened within a frame.
void ReadRunApp::printNotes() {
  const uint8_t notes = notes_;
  notes_ = 0;
  if (notes == 0) return;
  if (notes & kNoteHold) {
    say(TC_PSTR("# hold "));
    fw::printUint(liftoff_force_g_);
    say(TC_PSTR(" g for "));
    fw::printUint(liftoff_hold_ms_);
    sayLine(TC_PSTR(" ms"));
  }
  if (notes & kNoteProgress) printLiftoffProgress(note_ms_ - liftoff_start_ms_, note_force_g_);
  if (notes & kNoteDone) {
    sayLine(TC_PSTR("# liftoff done: motors stopped"));
    prompt();
  }
  if (notes & kNoteLinkLost) {
    fw::newline();
    sayLine(TC_PSTR("# liftoff stopped: no line end for 500 ms (keep it alive with empty lines; "
                    "any other key aborts): motors stopped"));
    prompt();
  }
  if (notes & kNoteFailsafe) {
    fw::newline();
    sayLine(TC_PSTR("failsafe: no command for 500 ms, motors stopped"));
    prompt();
  }
  if ((notes & kNoteStream) && stream_ && mode_ != Mode::kArming) streamLine(note_ms_);
}

void ReadRunApp::stopAll() {
  for (uint8_t i = 0; i < kMotors; ++i) {
    Motor& m = motors_[i];
    setForce(i, 0);
    m.pwm_us = kStopPwmUs;
    m.flags = m.isArmable() ? tc::kStopped : tc::kNotCalibrated;
    hal::Esc::writePulse(i, kStopPwmUs);
  }
}

void ReadRunApp::prompt() { say(TC_PSTR("rr> ")); }

// ---------------------------------------------------------------------------------------------
// ESC frames (integer only)

void ReadRunApp::scheduleFrames(uint32_t now_ms) {
  next_frame_ms_ = now_ms;
  frame_rem_ = 0;
  stream_countdown_ = 0;
}

bool ReadRunApp::frameDue(uint32_t now_ms) const {
  return static_cast<int32_t>(now_ms - next_frame_ms_) >= 0;
}

// v1 and status: the thesis median of 101. v2: this frame's four readings (middle two) into
// the frame of the v2 motors (tc::V2Frame: the bus filter, the sag prediction, every v2 motor's
// pulse), every frame while a v2 motor is loaded; an insane reading is skipped by the filter
// (it keeps the last good value) and flagged on the v2 motors' results.
void ReadRunApp::sampleBattery() {
  static_assert(kBatterySamplesPerFrame == 4, "middleTwoMillivolts takes four readings");
  uint16_t counts[kBatterySamplesPerFrame];
  for (uint8_t k = 0; k < kBatterySamplesPerFrame; ++k) {
    counts[k] = hal::Adc::readCounts(hal::kAdcBattery);
    battery_counts_.push(counts[k]);
  }
  battery_mv_ = monitor_.millivoltsFromCounts(battery_counts_.median());
  if (v2_.count == 0) return;
  const uint16_t frame_mv = middleTwoMillivolts(counts, monitor_);
  bus_sample_sane_ = monitor_.isSane(frame_mv);
  v2_.fly(frame_mv, bus_sample_sane_ ? 0 : tc::kVoltageInvalid);
}

// Filter constant per frame rate: 1/8 at 50-99 Hz, 1/16 at 100-199, 1/32 at 200-399, 1/64 at
// 400 Hz, so the time constant stays about 150 ms. A change re-seeds the filter at its value
// (one division) and rescales the motors' seen forces.
void ReadRunApp::setFilterShift(uint16_t frame_hz) {
  uint8_t shift = 3;
  for (uint16_t hz = 100; hz <= frame_hz && shift < 6; hz = static_cast<uint16_t>(hz * 2)) ++shift;
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
  next_frame_ms_ += 1000u / frame_hz_;
  frame_rem_ = static_cast<uint16_t>(frame_rem_ + 1000u % frame_hz_);
  if (frame_rem_ >= frame_hz_) {
    frame_rem_ = static_cast<uint16_t>(frame_rem_ - frame_hz_);
    ++next_frame_ms_;
  }
  if (frameDue(now_ms)) {  // fell behind (a long print): restart the schedule from now
    next_frame_ms_ = now_ms + 1000u / frame_hz_;
    frame_rem_ = 0;
  }

  if (mode_ == Mode::kLiftoff) updateLiftoff(now_ms);
  sampleBattery();
  for (uint8_t i = 0; i < kMotors; ++i) {
    flyMotor(motors_[i]);
    hal::Esc::writePulse(i, motors_[i].pwm_us);
  }

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

void ReadRunApp::streamLine(uint32_t now_ms) {
  fw::printFixed(static_cast<int32_t>(now_ms), 3);
  for (uint8_t i = 0; i < kMotors; ++i) {
    hal::Uart::write(',');
    fw::printUint(motors_[i].pwm_us);
  }
  hal::Uart::write(',');
  fw::printFixed(battery_mv_, 3);
  fw::newline();
}

// ---------------------------------------------------------------------------------------------
// Lift-off sequence (thesis sec. 7.4): all four motors the same force, ramp then hold

void ReadRunApp::updateLiftoff(uint32_t now_ms) {
  const uint32_t elapsed_ms = now_ms - liftoff_start_ms_;
  uint16_t force_g = liftoff_force_g_;
  if (elapsed_ms < liftoff_ramp_ms_) {
    force_g = static_cast<uint16_t>(static_cast<uint32_t>(liftoff_force_g_) * elapsed_ms /
                                    liftoff_ramp_ms_);
  } else if (elapsed_ms < static_cast<uint32_t>(liftoff_ramp_ms_) + liftoff_hold_ms_) {
    if (!liftoff_holding_) {
      liftoff_holding_ = true;
      notes_ |= kNoteHold;
    }
  } else {
    stopAll();
    mode_ = Mode::kReady;
    last_line_ms_ = now_ms;
    notes_ |= kNoteDone;
    return;
  }
  for (uint8_t i = 0; i < kMotors; ++i) setForce(i, force_g);
}

void ReadRunApp::printLiftoffProgress(uint32_t elapsed_ms, uint16_t force_g) {
  say(TC_PSTR("# t "));
  fw::printFixed(static_cast<int32_t>(elapsed_ms), 3);
  say(liftoff_holding_ ? TC_PSTR(" s hold ") : TC_PSTR(" s ramp "));
  fw::printUint(force_g);
  say(TC_PSTR(" g, pwm"));
  for (uint8_t i = 0; i < kMotors; ++i) {
    hal::Uart::write(' ');
    fw::printUint(motors_[i].pwm_us);
  }
  say(TC_PSTR(" us, battery "));
  sayVolts(battery_mv_);
  fw::newline();
}

void ReadRunApp::abortLiftoff(int16_t key) {
  line_.abortLine(key);  // the rest of the key's line is not a command ("xf 2 450")
  stopAll();
  notes_ &= static_cast<uint8_t>(~(kNoteProgress | kNoteHold));
  mode_ = Mode::kReady;
  last_line_ms_ = hal::Clock::millis();
  fw::newline();
  sayLine(TC_PSTR("# liftoff aborted by input: motors stopped"));
  prompt();
}

// ---------------------------------------------------------------------------------------------
// Commands

void ReadRunApp::handleLine(char* line) {
  char* tokens[kMaxTokens];
  const uint8_t count = fw::tokenize(line, tokens, kMaxTokens);
  if (count == 0) return;  // empty line: keep-alive only, no prompt (hosts send it 2x/s+)
  const char* verb = tokens[0];
  if (line_.handleStrict(tokens, count)) {
    prompt();
    return;
  }
  if (fw::equalsP(verb, TC_PSTR("help"))) {
    commandHelp();
  } else if (fw::equalsP(verb, TC_PSTR("f"))) {
    commandForce(tokens, count);
  } else if (fw::equalsP(verb, TC_PSTR("stop"))) {
    commandStop();
  } else if (fw::equalsP(verb, TC_PSTR("status"))) {
    commandStatus();
  } else if (fw::equalsP(verb, TC_PSTR("liftoff"))) {
    commandLiftoff(tokens, count);
    if (mode_ == Mode::kLiftoff) return;  // its progress lines follow; prompt at the end
  } else if (fw::equalsP(verb, TC_PSTR("stream"))) {
    commandStream(tokens, count);
    if (stream_) return;  // no prompt: the next line is a CSV row, and must start clean
  } else if (fw::equalsP(verb, TC_PSTR("rate"))) {
    commandRate(tokens, count);
  } else if (fw::equalsP(verb, TC_PSTR("divider"))) {
    commandDivider(tokens, count);
  } else if (fw::isEepromCommand(verb)) {
    if (isRunning()) {
      sayLine(TC_PSTR("error: eeprom: motors are running; send stop first"));
    } else {
      fw::eepromCommand(tokens, count);
    }
  } else {
    say(TC_PSTR("error: unknown command \""));
    hal::Uart::print(verb);
    sayLine(TC_PSTR("\"; type help for the list"));
  }
  prompt();
}

void ReadRunApp::commandHelp() {
  sayLine(TC_PSTR("f G            all calibrated motors to G grams (0..5000)"));
  sayLine(TC_PSTR("f N G          motor N (0..3) to G grams"));
  sayLine(TC_PSTR("stop           all motors to 0 g (1000 us)"));
  sayLine(TC_PSTR("status         per motor: force, pwm, battery, flags; v2 motors: headroom"));
  sayLine(TC_PSTR("liftoff G [RAMP_MS] [HOLD_MS]  ramp all four 0->G g (default 2000 ms),"));
  sayLine(TC_PSTR("               hold (default 5000 ms), stop; empty lines keep it going,"));
  sayLine(TC_PSTR("               any other key aborts"));
  sayLine(TC_PSTR("stream on|off  CSV t_s,motor0_pwm_us..motor3_pwm_us,vbat_v, 10 lines/s"));
  sayLine(TC_PSTR("rate HZ        ESC frame rate 50..400 Hz (motors stopped)"));
  sayLine(TC_PSTR("eeprom crc|dump  EEPROM CRC-16 per slot and whole, or Intel HEX (stopped)"));
  sayLine(TC_PSTR("divider [R1 R2] battery divider in ohm, R1 pack-A1, R2 A1-ground (default"));
  sayLine(TC_PSTR("               100000 47000); setting it reloads the calibration (motors stopped)"));
  sayLine(TC_PSTR("strict on|off  f (above 0 g), liftoff, divider R1 R2 need a checksum"));
  sayLine(TC_PSTR("failsafe: while a motor runs, 500 ms without a line (an empty line will do;"));
  sayLine(TC_PSTR("with strict on a checksummed one, e.g. *00) stops all motors; during liftoff"));
  sayLine(TC_PSTR("empty lines keep it going and any other key aborts it"));
  sayLine(TC_PSTR("lines: CR, LF or CRLF, at most 48 characters; optional checksum *HH = XOR"));
  sayLine(TC_PSTR("of the line before '*'; a damaged line is rejected whole (docs/console.md)"));
}

bool ReadRunApp::requireArmable(uint8_t index) {
  const Motor& m = motors_[index];
  if (m.isArmable()) return true;
  say(TC_PSTR("error: "));
  sayMotor(index);
  say(TC_PSTR(" is "));
  sayRecordStatus(m);
  sayLine(TC_PSTR("; it stays at 1000 us - recalibrate it with gather_store"));
  return false;
}

void ReadRunApp::commandForce(char** tokens, uint8_t count) {
  int32_t motor = -1;
  int32_t force_g = 0;
  bool ok = false;
  if (count == 2) {
    ok = fw::parseInt(tokens[1], 0, kForceMaxG, force_g);
  } else if (count == 3) {
    ok = fw::parseInt(tokens[1], 0, kMotors - 1, motor) &&
         fw::parseInt(tokens[2], 0, kForceMaxG, force_g);
  }
  if (!ok) {
    sayLine(TC_PSTR("error: usage: f GRAMS (all motors) or f MOTOR GRAMS, GRAMS 0..5000, MOTOR 0..3"));
    return;
  }
  if (force_g > 0 && !line_.allowRisky()) return;  // stopping never needs a checksum
  if (motor >= 0) {
    if (!requireArmable(static_cast<uint8_t>(motor))) return;
    setForce(static_cast<uint8_t>(motor), static_cast<uint16_t>(force_g));
    return;
  }
  uint8_t armable = 0;
  for (uint8_t i = 0; i < kMotors; ++i) armable += motors_[i].isArmable() ? 1 : 0;
  if (armable == 0) {
    sayLine(TC_PSTR("error: no motor is calibrated; calibrate them with gather_store first"));
    return;
  }
  for (uint8_t i = 0; i < kMotors; ++i) {
    Motor& m = motors_[i];
    if (m.isArmable()) {
      setForce(i, static_cast<uint16_t>(force_g));
    } else {
      say(TC_PSTR("warning: "));
      sayMotor(i);
      say(TC_PSTR(" "));
      sayRecordStatus(m);
      sayLine(TC_PSTR("; held at 1000 us"));
    }
  }
}

void ReadRunApp::commandStop() {
  stopAll();
  sayLine(TC_PSTR("stopped: every ESC at 1000 us"));
}

void ReadRunApp::commandStatus() {
  for (uint8_t i = 0; i < kMotors; ++i) {
    const Motor& m = motors_[i];
    sayMotor(i);
    say(TC_PSTR(": "));
    if (!m.isArmable()) {
      sayRecordStatus(m);
      say(TC_PSTR("; held at "));
      fw::printUint(m.pwm_us);
      sayLine(TC_PSTR(" us"));
      continue;
    }
    fw::printUint(m.force_g);
    say(TC_PSTR(" g, "));
    fw::printUint(m.pwm_us);
    say(TC_PSTR(" us, battery "));
    sayVolts(m.vbat_mv);
    if (m.fliesV2()) {
      // Headroom: the most this motor reaches at the present (filtered) voltage with the
      // ESC at its maximum pulse. One division: status only, never per frame.
      say(TC_PSTR(" filtered, headroom "));
      fw::printUint(gramsFromDg(tc::headroomDg(m.model.v2(), v2_.bus.isValid() ? v2_.bus.mv
                                                                              : m.model.v2().rest_mv)));
      say(TC_PSTR(" g, flags: "));
    } else {
      say(TC_PSTR(" compensated, flags: "));
    }
    sayFlags(m.flags);
    fw::newline();
  }
  if (v2_.count != 0) {
    say(TC_PSTR("bus filter "));
    sayVolts(v2_.bus.mv);
    say(TC_PSTR(" (v2 motors: 1/"));
    fw::printUint(1u << v2_.bus.shift);
    say(TC_PSTR(" per frame), readings rejected "));
    fw::printUint(v2_.bus.rejected);
    fw::newline();
  }
  say(TC_PSTR("battery "));
  sayVolts(battery_mv_);
  say(TC_PSTR(" raw (median of 101), frame rate "));
  fw::printUint(frame_hz_);
  say(TC_PSTR(" Hz, "));
  say(isRunning() ? TC_PSTR("running") : TC_PSTR("stopped"));
  say(TC_PSTR(", failsafe trips "));
  fw::printUint(failsafe_trips_);
  fw::newline();
  fw::printHealth(line_, &ReadRunApp::serviceHook);  // frames go on during the stack scan
}

void ReadRunApp::commandLiftoff(char** tokens, uint8_t count) {
  int32_t force_g = 0;
  uint16_t ramp_ms = kLiftoffDefaultRampMs;
  uint16_t hold_ms = kLiftoffDefaultHoldMs;
  const bool ok = count >= 2 && count <= 4 && fw::parseInt(tokens[1], 1, kForceMaxG, force_g) &&
                  (count < 3 || parseMs(tokens[2], ramp_ms)) &&
                  (count < 4 || parseMs(tokens[3], hold_ms));
  if (!ok) {
    sayLine(TC_PSTR("error: usage: liftoff GRAMS [RAMP_MS] [HOLD_MS], GRAMS 1..5000, times "
                    "0..60000 ms"));
    return;
  }
  if (!line_.allowRisky()) return;
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (!motors_[i].isArmable()) {
      say(TC_PSTR("error: liftoff needs all four motors calibrated; "));
      sayMotor(i);
      say(TC_PSTR(" is "));
      sayRecordStatus(motors_[i]);
      sayLine(TC_PSTR("; recalibrate it with gather_store"));
      return;
    }
  }
  if (isRunning()) {
    sayLine(TC_PSTR("error: motors are running; send stop first, then liftoff"));
    return;
  }
  const uint32_t now_ms = hal::Clock::millis();
  liftoff_force_g_ = static_cast<uint16_t>(force_g);
  liftoff_ramp_ms_ = ramp_ms;
  liftoff_hold_ms_ = hold_ms;
  liftoff_start_ms_ = now_ms;
  liftoff_next_progress_ms_ = now_ms;
  liftoff_holding_ = false;
  last_line_ms_ = now_ms;  // the link timeout counts from the command
  mode_ = Mode::kLiftoff;
  say(TC_PSTR("# liftoff: ramp 0 -> "));
  fw::printUint(liftoff_force_g_);
  say(TC_PSTR(" g in "));
  fw::printUint(ramp_ms);
  say(TC_PSTR(" ms, hold "));
  fw::printUint(hold_ms);
  sayLine(TC_PSTR(" ms, then stop; empty lines keep it going (at least every 500 ms), any "
                  "other key aborts"));
}

void ReadRunApp::commandStream(char** tokens, uint8_t count) {
  if (count == 2 && fw::equalsP(tokens[1], TC_PSTR("on"))) {
    sayLine(TC_PSTR("t_s,motor0_pwm_us,motor1_pwm_us,motor2_pwm_us,motor3_pwm_us,vbat_v"));
    stream_ = true;
    stream_countdown_ = 0;
  } else if (count == 2 && fw::equalsP(tokens[1], TC_PSTR("off"))) {
    stream_ = false;
    sayLine(TC_PSTR("# stream off"));
  } else {
    sayLine(TC_PSTR("error: usage: stream on|off"));
  }
}

void ReadRunApp::commandRate(char** tokens, uint8_t count) {
  int32_t hz = 0;
  if (count != 2 || !fw::parseInt(tokens[1], hal::kEscMinFrameHz, hal::kEscMaxFrameHz, hz)) {
    sayLine(TC_PSTR("error: rate must be 50..400 Hz, e.g. rate 400"));
    return;
  }
  if (isRunning()) {
    sayLine(TC_PSTR("error: motors are running; send stop first, then change the rate"));
    return;
  }
  if (!hal::Esc::setFrameRate(static_cast<uint16_t>(hz))) {
    sayLine(TC_PSTR("error: the ESC driver refused that rate; try 50..400 Hz"));
    return;
  }
  frame_hz_ = static_cast<uint16_t>(hz);
  setFilterShift(frame_hz_);
  stream_every_frames_ = static_cast<uint8_t>(frame_hz_ / kStreamLinesPerSecond);
  scheduleFrames(hal::Clock::millis());
  say(TC_PSTR("frame rate "));
  fw::printUint(frame_hz_);
  sayLine(TC_PSTR(" Hz"));
}

}  // namespace rr

namespace rr {

// `divider [R1 R2]`: the battery monitor's divider (thrustcal/board_settings.hpp). A new value
// is stored, then the calibration is loaded again against it: volts come from counts through
// it, and a record's voltages must lie within its full scale.
void ReadRunApp::commandDivider(char** tokens, uint8_t count) {
  if (count > 1 && isRunning()) {
    sayLine(TC_PSTR("error: motors are running; send stop first, then set the divider"));
    return;
  }
  if (count > 1 && !line_.allowRisky()) return;  // writes the EEPROM: strict needs a checksum
  if (!fw::commandDivider(tokens, count, settings_)) return;
  const uint8_t shift = v2_.bus.shift;
  v2_.bus = tc::BusVoltageFilter();  // its millivolts came through the old divider
  v2_.bus.shift = shift;
  v2_.sag = tc::BusSagFilter();
  bus_sample_sane_ = false;
  loadCalibration();
}

}  // namespace rr

// Read and Run: see read_run_app.hpp for the flow and the safety rules.
#include "read_run_app.hpp"

namespace rr {

namespace {

constexpr uint8_t kMaxTokens = 6;

void say(const char* progmem_text) { hal::Uart::printP(progmem_text); }

void sayLine(const char* progmem_text) {
  hal::Uart::printP(progmem_text);
  fw::newline();
}

void sayVolts(uint16_t mv) {
  fw::printFixed(mv, 3);
  say(TC_PSTR(" V"));
}

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

void sayRecordStatus(tc::DecodeStatus status) {
  say(TC_PSTR("not calibrated: "));
  hal::Uart::print(tc::decodeStatusText(status));
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
  sayLine(TC_PSTR("type help for commands; while motors run send a line at least every 500 ms"));
}

uint8_t ReadRunApp::loadCalibration() {
  uint8_t calibrated = 0;
  for (uint8_t i = 0; i < kMotors; ++i) {
    Motor& m = motors_[i];
    m.record = tc::readRecord<hal::Eeprom>(i, m.cal);
    m.force_g = 0;
    m.pwm_us = kStopPwmUs;
    m.flags = m.isArmable() ? tc::kStopped : tc::kNotCalibrated;
    sayMotor(i);
    say(TC_PSTR(": "));
    if (m.isArmable()) {
      ++calibrated;
      say(TC_PSTR("ok, V1 "));
      sayVolts(m.cal.first.start_mv);
      say(TC_PSTR(", V2 "));
      if (m.cal.hasSecondCurve()) {
        sayVolts(m.cal.second.start_mv);
      } else {
        say(TC_PSTR("none (single curve, no voltage compensation)"));
      }
      say(TC_PSTR(", max "));
      fw::printUint(reachableGrams(m.cal));
      say(TC_PSTR(" g"));
    } else {
      sayRecordStatus(m.record);
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
    motors_[i].force_g = 0;
    motors_[i].pwm_us = kStopPwmUs;
    hal::Esc::writePulse(i, kStopPwmUs);
  }
  frame_hz_ = hal::Esc::frameRateHz();
  if (frame_hz_ < hal::kEscMinFrameHz || frame_hz_ > hal::kEscMaxFrameHz) {
    frame_hz_ = hal::kEscDefaultFrameHz;
  }
  stream_every_frames_ = static_cast<uint8_t>(frame_hz_ / kStreamLinesPerSecond);
  const uint32_t start_ms = hal::Clock::millis();
  scheduleFrames(start_ms);
  for (;;) {
    const uint32_t now_ms = hal::Clock::millis();
    if (now_ms - start_ms >= kArmMs) break;
    // Forces are 0: every frame writes 1000 us and feeds the battery median.
    if (frameDue(now_ms)) frame(now_ms);
    hal::Clock::sleepUntilInterrupt();
  }
  bool discarded = false;
  while (hal::Uart::read() >= 0) discarded = true;
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

void ReadRunApp::runOnce() {
  uint32_t now_ms = hal::Clock::millis();
  if (mode_ == Mode::kLiftoff) {
    if (hal::Uart::available()) abortLiftoff();
  } else if (mode_ == Mode::kReady) {
    for (;;) {
      const fw::LineEvent event = line_.poll();
      if (event == fw::LineEvent::kNone) break;
      last_line_ms_ = now_ms;  // any complete line is a keep-alive
      if (event == fw::LineEvent::kTooLong) {
        sayLine(TC_PSTR("error: line too long (at most 48 characters); nothing changed"));
        prompt();
        continue;
      }
      char line[fw::kLineMax + 1];
      const char* src = line_.line();
      uint8_t n = 0;
      while (n < fw::kLineMax && src[n] != '\0') {
        line[n] = src[n];
        ++n;
      }
      line[n] = '\0';
      line_.clear();
      handleLine(line);
      if (mode_ == Mode::kLiftoff) break;  // the rest of the input is the abort key
    }
    checkFailsafe(now_ms);
  }
  now_ms = hal::Clock::millis();  // printing may have taken time on the board
  if (frameDue(now_ms)) frame(now_ms);
}

void ReadRunApp::checkFailsafe(uint32_t now_ms) {
  if (mode_ != Mode::kReady || !isRunning()) return;
  if (now_ms - last_line_ms_ < kFailsafeMs) return;
  stopAll();
  ++failsafe_trips_;
  fw::newline();
  sayLine(TC_PSTR("failsafe: no command for 500 ms, motors stopped"));
  prompt();
}

void ReadRunApp::stopAll() {
  for (uint8_t i = 0; i < kMotors; ++i) {
    Motor& m = motors_[i];
    m.force_g = 0;
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

void ReadRunApp::sampleBattery() {
  for (uint8_t k = 0; k < kBatterySamplesPerFrame; ++k) {
    battery_counts_.push(hal::Adc::readCounts(hal::kAdcBattery));
  }
  battery_mv_ = monitor_.millivoltsFromCounts(battery_counts_.median());
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
    Motor& m = motors_[i];
    if (!m.isArmable()) {
      m.force_g = 0;
      m.pwm_us = kStopPwmUs;
      m.flags = tc::kNotCalibrated;
      m.vbat_mv = battery_mv_;
    } else {
      // Thesis fig. 6.9: the reading sags under this motor's load; add the offset of the
      // PWM it was last sent.
      m.vbat_mv = monitor_.compensatedMillivolts(battery_mv_, m.pwm_us, m.cal.sag);
      const tc::ForcePwmResult result = tc::forceToPwm(m.cal, m.force_g, m.vbat_mv);
      m.pwm_us = result.pwm_us;
      m.flags = result.flags;
    }
    hal::Esc::writePulse(i, m.pwm_us);
  }

  if (mode_ == Mode::kLiftoff) {
    const uint32_t elapsed_ms = now_ms - liftoff_start_ms_;
    if (static_cast<int32_t>(now_ms - liftoff_next_progress_ms_) >= 0) {
      liftoff_next_progress_ms_ += kLiftoffProgressMs;
      printLiftoffProgress(elapsed_ms, motors_[0].force_g);
    }
  }
  if (stream_ && mode_ != Mode::kArming) {
    if (stream_countdown_ == 0) {
      streamLine(now_ms);
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
      say(TC_PSTR("# hold "));
      fw::printUint(liftoff_force_g_);
      say(TC_PSTR(" g for "));
      fw::printUint(liftoff_hold_ms_);
      sayLine(TC_PSTR(" ms"));
    }
  } else {
    stopAll();
    mode_ = Mode::kReady;
    last_line_ms_ = now_ms;
    sayLine(TC_PSTR("# liftoff done: motors stopped"));
    prompt();
    return;
  }
  for (uint8_t i = 0; i < kMotors; ++i) motors_[i].force_g = force_g;
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

void ReadRunApp::abortLiftoff() {
  while (hal::Uart::read() >= 0) {
  }
  line_.clear();
  stopAll();
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
  } else {
    say(TC_PSTR("error: unknown command \""));
    hal::Uart::print(verb);
    sayLine(TC_PSTR("\"; type help for the list"));
  }
  prompt();
}

void ReadRunApp::commandHelp() {
  sayLine(TC_PSTR("f G            all calibrated motors to G grams (0..500)"));
  sayLine(TC_PSTR("f N G          motor N (0..3) to G grams"));
  sayLine(TC_PSTR("stop           all motors to 0 g (1000 us)"));
  sayLine(TC_PSTR("status         per motor: force, pwm, flags, compensated battery"));
  sayLine(TC_PSTR("liftoff G [RAMP_MS] [HOLD_MS]  ramp all four 0->G g (default 2000 ms),"));
  sayLine(TC_PSTR("               hold (default 5000 ms), stop; any key aborts"));
  sayLine(TC_PSTR("stream on|off  CSV t_s,motor0_pwm_us..motor3_pwm_us,vbat_v, 10 lines/s"));
  sayLine(TC_PSTR("rate HZ        ESC frame rate 50..400 Hz (motors stopped)"));
  sayLine(TC_PSTR("failsafe: while a motor runs, 500 ms without a line (an empty line will do)"));
  sayLine(TC_PSTR("stops all motors"));
}

bool ReadRunApp::requireArmable(uint8_t index) {
  const Motor& m = motors_[index];
  if (m.isArmable()) return true;
  say(TC_PSTR("error: "));
  sayMotor(index);
  say(TC_PSTR(" is "));
  sayRecordStatus(m.record);
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
    sayLine(TC_PSTR("error: usage: f GRAMS (all motors) or f MOTOR GRAMS, GRAMS 0..500, MOTOR 0..3"));
    return;
  }
  if (motor >= 0) {
    if (!requireArmable(static_cast<uint8_t>(motor))) return;
    motors_[motor].force_g = static_cast<uint16_t>(force_g);
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
      m.force_g = static_cast<uint16_t>(force_g);
    } else {
      say(TC_PSTR("warning: "));
      sayMotor(i);
      say(TC_PSTR(" "));
      sayRecordStatus(m.record);
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
      sayRecordStatus(m.record);
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
    say(TC_PSTR(" compensated, flags: "));
    sayFlags(m.flags);
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
}

void ReadRunApp::commandLiftoff(char** tokens, uint8_t count) {
  int32_t force_g = 0;
  uint16_t ramp_ms = kLiftoffDefaultRampMs;
  uint16_t hold_ms = kLiftoffDefaultHoldMs;
  const bool ok = count >= 2 && count <= 4 && fw::parseInt(tokens[1], 1, kForceMaxG, force_g) &&
                  (count < 3 || parseMs(tokens[2], ramp_ms)) &&
                  (count < 4 || parseMs(tokens[3], hold_ms));
  if (!ok) {
    sayLine(TC_PSTR("error: usage: liftoff GRAMS [RAMP_MS] [HOLD_MS], GRAMS 1..500, times "
                    "0..60000 ms"));
    return;
  }
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (!motors_[i].isArmable()) {
      say(TC_PSTR("error: liftoff needs all four motors calibrated; "));
      sayMotor(i);
      say(TC_PSTR(" is "));
      sayRecordStatus(motors_[i].record);
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
  mode_ = Mode::kLiftoff;
  say(TC_PSTR("# liftoff: ramp 0 -> "));
  fw::printUint(liftoff_force_g_);
  say(TC_PSTR(" g in "));
  fw::printUint(ramp_ms);
  say(TC_PSTR(" ms, hold "));
  fw::printUint(hold_ms);
  sayLine(TC_PSTR(" ms, then stop; any key aborts"));
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
  stream_every_frames_ = static_cast<uint8_t>(frame_hz_ / kStreamLinesPerSecond);
  scheduleFrames(hal::Clock::millis());
  say(TC_PSTR("frame rate "));
  fw::printUint(frame_hz_);
  sayLine(TC_PSTR(" Hz"));
}

}  // namespace rr

// Read and Run: see read_run_app.hpp for the flow and the safety rules. This file is the
// controller's life cycle: start-up (the records, arming), the main loop's pass (input, the
// time-critical service, its notes), the failsafe and the lift-off sequence. The ESC frame is
// in frame.cpp, the commands in commands.cpp, every printed line in console_view.cpp.
#include "read_run_app.hpp"

#include "console_view.hpp"

namespace rr {

ReadRunApp* ReadRunApp::active_ = nullptr;

// ---------------------------------------------------------------------------------------------
// Start-up

void ReadRunApp::printBanner() { view::banner(); }

uint8_t ReadRunApp::loadCalibration() {
  uint8_t calibrated = 0;
  v2_.count = 0;
  // The board's divider first: counts -> volts, and the voltages a record may hold.
  tc::readSettings<hal::Eeprom>(settings_);
  monitor_ = tc::BatteryMonitor(settings_.batteryConfig());
  const tc::RecordLimits limits = settings_.recordLimits();
  fw::say(TC_FLASH_TEXT("battery monitor: "));
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
    if (m.isArmable()) ++calibrated;
    view::slotLoaded(i, m, v2, v1);
  }
  view::calibratedCount(calibrated);
  return calibrated;
}

void ReadRunApp::arm() {
  mode_ = Mode::kArming;
  fw::sayLine(TC_FLASH_TEXT("arming... (every ESC at 1000 us for 2 s)"));
  static_assert(kArmMs == 2000 && kStopPwmUs == 1000, "the arming line says 1000 us for 2 s");
  stopAll();
  uint16_t frame_hz = hal::Esc::frameRateHz();
  if (frame_hz < hal::kEscMinFrameHz || frame_hz > hal::kEscMaxFrameHz) {
    frame_hz = hal::kEscDefaultFrameHz;
  }
  setFrameRate(frame_hz);
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
  fw::sayLine(TC_FLASH_TEXT("armed"));
  if (discarded) {
    fw::sayLine(TC_FLASH_TEXT("note: input received while arming was ignored; send commands after \"armed\""));
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
  if (frames_.due(now_ms)) frame(now_ms);
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
  handleLine(line);  // commands.cpp
}

// While a motor runs (lift-off included), no keep-alive for kFailsafeMs stops every motor.
void ReadRunApp::checkFailsafe(uint32_t now_ms) {
  if (mode_ == Mode::kLiftoff) {
    if (!linkLost(now_ms, last_line_ms_)) return;
    stopAll();
    mode_ = Mode::kReady;
    ++failsafe_trips_;
    notes_ |= kNoteLinkLost;
    return;
  }
  if (mode_ != Mode::kReady || !isRunning()) return;
  if (!linkLost(now_ms, last_line_ms_)) return;
  stopAll();
  ++failsafe_trips_;
  notes_ |= kNoteFailsafe;
}

// What service() had to say, in the order it happened within a frame.
void ReadRunApp::printNotes() {
  const uint8_t notes = notes_;
  notes_ = 0;
  if (notes == 0) return;
  if (notes & kNoteHold) view::liftoffHold(*this);
  if (notes & kNoteProgress) view::liftoffProgress(*this, note_ms_ - liftoff_start_ms_, note_force_g_);
  if (notes & kNoteDone) {
    view::liftoffDone();
    prompt();
  }
  if (notes & kNoteLinkLost) {
    view::liftoffLinkLost();
    prompt();
  }
  if (notes & kNoteFailsafe) {
    view::failsafe();
    prompt();
  }
  if ((notes & kNoteStream) && stream_ && mode_ != Mode::kArming) view::streamRow(*this, note_ms_);
}

void ReadRunApp::stopAll() {
  uint16_t pulses_us[kMotors];
  for (uint8_t i = 0; i < kMotors; ++i) {
    Motor& m = motors_[i];
    setForce(i, 0);
    m.pwm_us = kStopPwmUs;
    m.flags = m.isArmable() ? tc::kStopped : tc::kNotCalibrated;
    pulses_us[i] = kStopPwmUs;
  }
  hal::Esc::writeAll(pulses_us);
}

void ReadRunApp::prompt() { fw::say(TC_FLASH_TEXT("rr> ")); }

// ---------------------------------------------------------------------------------------------
// Lift-off sequence (thesis sec. 7.4): all four motors the same force, ramp then hold

void ReadRunApp::updateLiftoff(uint32_t now_ms) {
  const LiftoffStep step =
      liftoffStep(now_ms - liftoff_start_ms_, liftoff_force_g_, liftoff_ramp_ms_, liftoff_hold_ms_);
  if (step.phase == LiftoffPhase::kDone) {
    stopAll();
    mode_ = Mode::kReady;
    last_line_ms_ = now_ms;
    notes_ |= kNoteDone;
    return;
  }
  if (step.phase == LiftoffPhase::kHold && !liftoff_holding_) {
    liftoff_holding_ = true;
    notes_ |= kNoteHold;
  }
  for (uint8_t i = 0; i < kMotors; ++i) setForce(i, step.force_g);
}

void ReadRunApp::abortLiftoff(int16_t key) {
  line_.abortLine(key);  // the rest of the key's line is not a command ("xf 2 450")
  stopAll();
  notes_ &= static_cast<uint8_t>(~(kNoteProgress | kNoteHold));
  mode_ = Mode::kReady;
  last_line_ms_ = hal::Clock::millis();
  view::liftoffAborted();
  prompt();
}

}  // namespace rr

// Read and Run: see read_run_app.hpp for the flow and the safety rules. This file is the
// controller's life cycle: start-up (the records, arming), the main loop's pass (input, the
// time-critical service, its notes), the failsafe and the lift-off sequence. The frame's
// schedule is in frame.cpp, the commands in commands.cpp, every printed line in
// console_view.cpp; the motors themselves are fw::ForceActuators.
#include "read_run_app.hpp"

#include "console_view.hpp"
#include "record_report.hpp"
#include "slot_report.hpp"

namespace rr {

ReadRunApp* ReadRunApp::active_ = nullptr;

// ---------------------------------------------------------------------------------------------
// Start-up

void ReadRunApp::printBanner() { view::banner(); }

uint8_t ReadRunApp::loadCalibration() { return fw::loadAndReport(motors_); }

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
  active_ = this;
  scheduleFrames();
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
  link_.heard(hal::Clock::millis());
  fw::sayLine(TC_FLASH_TEXT("armed"));
  if (discarded) {
    fw::sayLine(TC_FLASH_TEXT("note: input received while arming was ignored; send commands after \"armed\""));
  }
  prompt();
}

// ---------------------------------------------------------------------------------------------
// Main loop

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
  if (frames_due_ != frames_served_) frame(now_ms);
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
        link_.heard(now_ms);
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
  if (!line_.strict() || line_.checked()) link_.heard(now_ms);
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
    if (!link_.lost(now_ms)) return;
    stopAll();
    mode_ = Mode::kReady;
    ++link_.trips;
    notes_ |= kNoteLinkLost;
    return;
  }
  if (mode_ != Mode::kReady || !isRunning()) return;
  if (!link_.lost(now_ms)) return;
  stopAll();
  ++link_.trips;
  notes_ |= kNoteFailsafe;
}

// What service() had to say, in the order it happened within a frame.
void ReadRunApp::printNotes() {
  const uint8_t notes = notes_;
  notes_ = 0;
  if (notes == 0) return;
  if (notes & kNoteHold) view::liftoffHold(*this);
  if (notes & kNoteProgress) view::liftoffProgress(*this, note_ms_ - liftoff_.startMs(), note_force_g_);
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
  if ((notes & kNoteStream) && stream_.on && mode_ != Mode::kArming) view::streamRow(*this, note_ms_);
}

void ReadRunApp::prompt() { fw::say(TC_FLASH_TEXT("rr> ")); }

// ---------------------------------------------------------------------------------------------
// Lift-off sequence (thesis sec. 7.4): all four motors the same force, ramp then hold

void ReadRunApp::updateLiftoff(uint32_t now_ms) {
  const LiftoffStep step = liftoff_.step(now_ms);
  if (step.phase == LiftoffPhase::kDone) {
    stopAll();
    mode_ = Mode::kReady;
    link_.heard(now_ms);
    notes_ |= kNoteDone;
    return;
  }
  if (liftoff_.entersHold(step)) notes_ |= kNoteHold;
  for (uint8_t i = 0; i < kMotors; ++i) motors_.setForceDg(i, step.force_dg);
}

void ReadRunApp::abortLiftoff(int16_t key) {
  line_.abortLine(key);  // the rest of the key's line is not a command ("xf 2 450")
  stopAll();
  notes_ &= static_cast<uint8_t>(~(kNoteProgress | kNoteHold));
  mode_ = Mode::kReady;
  link_.heard(hal::Clock::millis());
  view::liftoffAborted();
  prompt();
}

}  // namespace rr

// read_run's ESC frame (thesis fig. 6.9, H.3): on the ESC frame's phase hook, the lift-off's
// step, the motors' frame (fw::ForceActuators: battery, models, the four pulses at once, carried
// by the next rising edge), then what the frame has to say (progress, a stream row), noted for
// printNotes(). Integer only; runs from service() (read_run_app.cpp), also inside a blocked UART
// write.
#include "read_run_app.hpp"

namespace rr {

void ReadRunApp::scheduleFrames() {
  frames_served_ = frames_due_;
  stream_.countdown = 0;
  hal::Esc::setPhaseHook(kFramePhaseUs, &ReadRunApp::phaseHook);
}

// Timer interrupt, once per ESC frame: short.
void ReadRunApp::phaseHook() {
  if (active_ != nullptr) active_->frames_due_ = static_cast<uint8_t>(active_->frames_due_ + 1);
}

void ReadRunApp::setFrameRate(uint16_t frame_hz) {
  frame_hz_ = frame_hz;
  motors_.setFrameRate(frame_hz);
  stream_.setFrameRate(frame_hz);
}

void ReadRunApp::frame(uint32_t now_ms) {
  const uint8_t due = frames_due_;
  if (static_cast<uint8_t>(due - frames_served_) > 1 && frames_skipped_ != 0xFFFF) ++frames_skipped_;
  frames_served_ = due;
  if (mode_ == Mode::kLiftoff) updateLiftoff(now_ms);
  motors_.frame();

  note_ms_ = now_ms;
  if (mode_ == Mode::kLiftoff && liftoff_.progressDue(now_ms)) {
    note_force_g_ = static_cast<uint16_t>((motors_.motor(0).force_dg + 5u) / 10u);  // printed in grams
    notes_ |= kNoteProgress;
  }
  if (stream_.on && mode_ != Mode::kArming && stream_.frameDue()) notes_ |= kNoteStream;
}

}  // namespace rr

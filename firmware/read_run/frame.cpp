// read_run's ESC frame (thesis fig. 6.9, H.3): on the frame schedule, the lift-off's step, the
// motors' frame (fw::ForceActuators: battery, models, the four pulses at once), then what the
// frame has to say (progress, a stream row), noted for printNotes(). Integer only; runs from
// service() (read_run_app.cpp), also inside a blocked UART write.
#include "read_run_app.hpp"

namespace rr {

void ReadRunApp::scheduleFrames(uint32_t now_ms) {
  frames_.restart(now_ms);
  stream_.countdown = 0;
}

void ReadRunApp::setFrameRate(uint16_t frame_hz) {
  frame_hz_ = frame_hz;
  motors_.setFrameRate(frame_hz);
  stream_.setFrameRate(frame_hz);
}

void ReadRunApp::frame(uint32_t now_ms) {
  frames_.advance(now_ms, frame_hz_);
  if (mode_ == Mode::kLiftoff) updateLiftoff(now_ms);
  motors_.frame();

  note_ms_ = now_ms;
  if (mode_ == Mode::kLiftoff && liftoff_.progressDue(now_ms)) {
    note_force_g_ = motors_.motor(0).force_g;
    notes_ |= kNoteProgress;
  }
  if (stream_.on && mode_ != Mode::kArming && stream_.frameDue()) notes_ |= kNoteStream;
}

}  // namespace rr

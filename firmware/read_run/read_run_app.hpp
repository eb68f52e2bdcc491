// Read and Run (thesis sec. 6.5, appendix H): the flight-side program.
//
// Flow (main.cpp): hardware init -> banner -> loadCalibration() (H.2: the four EEPROM
// records, read once into per-motor structs) -> arm() (1000 us for 2 s) -> runOnce() forever,
// sleeping until the next interrupt between passes. Every ESC frame (its phase hook,
// kFramePhaseUs after the rising edge) each motor's force command (decigrams: the console's
// grams, the lift-off's ramp) becomes a PWM through the model its slot holds:
//  - layout v1 (the thesis record, the baseline): the Force-PWM controller (H.3, option 2.1)
//    at the median battery reading, sag-compensated with that motor's offsets and last PWM
//    (sec. 6.2);
//  - layout v2 (thrustcal/model_v2.hpp): force is a curve in effective motor voltage
//    (pwm - start) * V_bus; PWM = start + drive(F) / V at the bus voltage filter (this frame's
//    reading, first-order IIR with a time constant of about 150 ms at every frame rate), the
//    bench sag of the step from the force the reading reflects to the command predicted.
//    Force beyond what the present voltage reaches saturates at the ESC maximum (flag
//    "saturated"); status shows each v2 motor's headroom.
// The slot loader (thrustcal/record_v2.hpp, tc::loadSlot) tells the layouts apart; a v2 slot
// keeps two copies and flies the newest valid one.
//
// Safety rules, all enforced here:
//  - a motor without a valid record (erased, bad version, bad CRC, bad content; for v2: both
//    copies bad) is never armed: it is held at 1000 us and every command to it is refused;
//    a record that cannot be right (thrustcal/plausibility.hpp: flat, non-monotone, pulses
//    outside the ESC range, voltages outside the monitor's range...) is bad content, and the
//    start-up report and `status` say which rule it broke;
//  - the battery monitor's divider is a stored board setting (thrustcal/board_settings.hpp,
//    `divider` command, default 100k/47k): counts -> volts and the voltage range a record may
//    hold follow it;
//  - failsafe: while any motor is commanded above 0 g, 500 ms without a keep-alive stops all
//    motors. The keep-alive is a complete, intact line (fw::LineReader: nothing lost or
//    garbled, text only, within 48 characters, checksum right when present), even an empty one
//    or one whose command is refused; with strict on only a line with a valid checksum counts
//    (an empty line: "*00"). Stray bytes and damaged lines keep nothing alive;
//  - the lift-off sequence drives the motors itself: empty lines (a bare CR, LF or CRLF) keep
//    it going, 500 ms without one stops it (loss of link), and any other byte aborts it at
//    once; the rest of that byte's line is discarded, never executed ("xf 2 450");
//  - commands that spin a motor (f above 0 g, liftoff) need a checksum with strict on;
//  - the main loop's period is bounded: one pass handles at most one input event of at most
//    kRxBytesPerPass bytes, serves the ESC frame, the failsafe and the lift-off timeout
//    (service()), then prints what service() noted. A reply longer than the transmit ring blocks in
//    hal::Uart::write, which runs service() from its wait hook, so frames stay on time;
//  - service() kicks the watchdog; nothing else in the loop does (docs/safety.md).
//
// Parts, one job each: fw::ForceActuators (the force API: the four slots, the battery, the ESC
// frame; firmware/common), Liftoff (liftoff.hpp), LinkWatch and StreamPace (run_rules.hpp),
// the console's fw::LineReader. Files: read_run_app.cpp (start-up, the loop's pass, failsafe,
// lift-off), frame.cpp (the frame's schedule and what it notes), commands.cpp (the command
// table and what each command does), console_view.cpp (every line printed).
//
// The per-frame path (battery samples, voltage filter, both models, ESC write) is integer
// only; the image links no floating-point routine at all. Host tests drive the same class
// against the fake HAL.
#pragma once
#include <stdint.h>

#include "console.hpp"
#include "force_actuators.hpp"
#include "shell.hpp"
#include "hal/hal.hpp"
#include "liftoff.hpp"
#include "run_rules.hpp"
#include "thrustcal/limits.hpp"

namespace rr {

using fw::Motor;
constexpr uint8_t kMotors = fw::ForceActuators::kMotors;
static_assert(kMotors == hal::kEscChannels, "one ESC output per calibration slot");

using tc::kArmMs;  // thrustcal/limits.hpp
using tc::kFailsafeMs;
using tc::kStopPwmUs;
constexpr uint16_t kForceMaxG = tc::kRecordMaxForceG;  // 5 kg: v1 curves saturate at 500 g
// Received bytes one loop pass handles at most: one longest line and its CR LF.
constexpr uint8_t kRxBytesPerPass = fw::kLineMax + 2;

enum class Mode : uint8_t {
  kBoot,     // before arm()
  kArming,   // 1000 us on every ESC, input ignored
  kReady,    // accepting commands (motors stopped or running)
  kLiftoff,  // the lift-off sequence drives the motors
};

class ReadRunApp {
 public:
  // Prints the program name and how to get help.
  void printBanner();
  // H.2: reads the board settings and the four EEPROM records once and reports each slot.
  // Returns how many motors are calibrated.
  uint8_t loadCalibration();
  // Holds every ESC at 1000 us for kArmMs while the battery median fills; input received
  // meanwhile is discarded (a command typed before "armed" never spins a motor). Blocks.
  void arm();
  // One pass of the main loop: at most one input event (a line, or the lift-off's keep-alives
  // and abort key), service(), then the notes service() left. Does not sleep: the caller
  // sleeps until the next interrupt afterwards.
  void runOnce();

  // Observers (status command, tests).
  const fw::ForceActuators& motors() const { return motors_; }
  const Motor& motor(uint8_t index) const { return motors_.motor(index); }
  Mode mode() const { return mode_; }
  bool isRunning() const { return motors_.isRunning(); }  // any motor commanded above 0 g
  uint16_t batteryMv() const { return motors_.batteryMv(); }  // median reading, uncompensated
  const tc::BusVoltageFilter& busFilter() const { return motors_.busFilter(); }
  const tc::BusSagFilter& sagFilter() const { return motors_.sagFilter(); }
  bool isStreaming() const { return stream_.on; }
  uint16_t frameHz() const { return frame_hz_; }
  const Liftoff& liftoff() const { return liftoff_; }
  uint32_t failsafeTrips() const { return link_.trips; }
  uint16_t framesSkipped() const { return frames_skipped_; }
  const fw::LineReader& console() const { return line_; }

  // `help`: every row of the command table (usage, help text, ranges), then the console rules
  // with their constants. docs/read_run.md holds a copy a test compares with it.
  static void printHelp();

 private:
  friend struct Commands;  // commands.cpp: the table's handlers, one call each to a cmd method

  // Commands (commands.cpp), arguments parsed and range-checked by the table.
  void cmdForceAll(uint16_t force_g);
  void cmdForceOne(uint8_t index, uint16_t force_g);
  void cmdStop();
  void cmdStatus();
  void cmdLiftoff(uint16_t force_g, uint16_t ramp_ms, uint16_t hold_ms);
  void cmdStream(bool on);
  void cmdRate(uint16_t frame_hz);
  void cmdEeprom(bool dump);
  void cmdDividerShow();
  void cmdDivider(uint32_t top_ohm, uint32_t bottom_ohm);
  void cmdStrict(bool on);
  void cmdDyn(const fw::ArgValues& args);

  void handleLine(char* line);
  bool requireArmable(uint8_t index) const;  // prints the refusal when not
  void stopAll() { motors_.stopAll(); }     // forces to 0, every ESC to 1000 us at once

  // The time-critical part of a pass, also run from inside a blocked write (the UART wait
  // hook): kicks the watchdog, the ESC frame when due, the failsafe and the lift-off link
  // timeout. Prints nothing: it leaves notes_ for printNotes().
  void service();
  static void serviceHook();
  void handleInput();
  void printNotes();
  void checkFailsafe(uint32_t now_ms);
  void abortLiftoff(int16_t key);
  void updateLiftoff(uint32_t now_ms);

  // The frames begin (again): the phase hook on the ESC frame at this rate.
  void scheduleFrames();
  static void phaseHook();
  void setFrameRate(uint16_t frame_hz);  // filter constant and stream pace follow it
  void frame(uint32_t now_ms);
  void prompt();

  fw::ForceActuators motors_;
  Liftoff liftoff_;
  LinkWatch link_;        // last keep-alive (lift-off: last line end), failsafe trips
  StreamPace stream_;
  // ESC frames: the phase hook counts them (interrupt), service() serves them.
  volatile uint8_t frames_due_ = 0;
  uint8_t frames_served_ = 0;
  uint16_t frames_skipped_ = 0;  // frames the loop was too late for (saturates)
  uint16_t frame_hz_ = hal::kEscDefaultFrameHz;
  fw::LineReader line_;
  Mode mode_ = Mode::kBoot;
  bool in_service_ = false;
  bool hold_prompt_ = false;  // the command's reply goes on (lift-off progress, stream rows)

  // service() -> printNotes(): what happened, and the frame it is about.
  static constexpr uint8_t kNoteHold = 0x01;
  static constexpr uint8_t kNoteProgress = 0x02;
  static constexpr uint8_t kNoteDone = 0x04;
  static constexpr uint8_t kNoteLinkLost = 0x08;
  static constexpr uint8_t kNoteFailsafe = 0x10;
  static constexpr uint8_t kNoteStream = 0x20;
  uint8_t notes_ = 0;
  uint16_t note_force_g_ = 0;   // lift-off progress: force at that frame
  uint32_t note_ms_ = 0;        // time of the frame the notes are about
  static ReadRunApp* active_;   // the instance the UART wait hook and the phase hook serve
};

}  // namespace rr

// The RC receiver, decoded: the edges hal::Rc timestamps (port K's pin changes, 0.5 us ticks)
// into frames of channel pulses, and the frames into sticks. A stage of fly's loop beside the
// IMU: RcFrame out, no other stage's types in; pure (no HAL), so its tests feed it edges.
//
// PPM sum (one pin, A8): a receiver sends each frame as a train of short separators (either
// polarity) whose starts are one channel's pulse apart, then a sync gap. A channel is the time
// between two falling edges; an interval of kRcSyncMinUs or more is the gap that ends a frame.
// PWM (one pin per channel, A8 = channel 1 ...): a channel is the time from its pin's rising
// edge to its falling edge; a frame is complete when every wired channel has brought a new
// pulse.
// Noise is rejected and counted: a pulse outside kRcMinUs..kRcMaxUs (a glitch, a spike, a
// receiver's own failsafe of 0 or 3000 us) is `rejected`; a PPM frame with such a pulse, with
// fewer than kRcMinChannels or more than kRcMaxChannels channels, or with another number of
// channels than the last valid frame (unless two frames in a row agree on it) is a `bad frame`,
// never flown. Only whole, valid frames leave the decoder; the failsafe (every ESC at the stop
// pulse within kRcStopMs of the last valid frame) is the app's (fly_rules.hpp, fly_app.cpp).
#pragma once
#include <stdint.h>

#include "flight_types.hpp"

namespace fly {

constexpr uint8_t kRcMaxChannels = 8;
constexpr uint8_t kRcMinChannels = 4;      // roll, pitch, throttle, yaw
constexpr uint16_t kRcMinUs = 800;         // a valid pulse (the usual 1000..2000 with margin)
constexpr uint16_t kRcMaxUs = 2200;
constexpr uint16_t kRcSyncMinUs = 2700;    // PPM: longer than any channel, shorter than any gap
constexpr uint16_t kRcEdgeGapMs = 25;      // no edge this long: the timestamps may have wrapped

enum class RcProtocol : uint8_t { kOff, kPpm, kPwm };

// An edge as hal::Rc gives it: the watched pins after the change, 0.5 us ticks (16 bits).
struct RcEdge {
  uint8_t pins;
  uint16_t ticks;
};

struct RcFrame {
  uint16_t us[kRcMaxChannels] = {0, 0, 0, 0, 0, 0, 0, 0};
  uint8_t channels = 0;
};

class RcDecoder {
 public:
  // Starts decoding `protocol`; PWM waits for `pwm_channels` (kRcMinChannels..8) per frame.
  void begin(RcProtocol protocol, uint8_t pwm_channels);
  RcProtocol protocol() const { return protocol_; }
  uint8_t pwmChannels() const { return pwm_channels_; }
  // One edge; true when it completed a valid frame (frame() holds it).
  bool edge(const RcEdge& e);
  // Edges were lost: the next edge starts afresh, and PPM waits for a sync gap before it times
  // a channel (no interval is taken across the gap).
  void gap();
  // No edge came for kRcEdgeGapMs (the 16-bit ticks may have wrapped: no interval is taken
  // across it). The line was idle, which for PPM is a sync gap: the next falling edge starts a
  // frame (a line that comes back in the middle of a frame gives fewer channels than the
  // receiver sends: a bad frame, below). So a dropout of one PPM frame costs one frame, not two
  // more while the decoder waits for a sync gap.
  void silence();
  const RcFrame& frame() const { return frame_; }

  uint32_t frames() const { return frames_; }            // valid frames decoded
  uint32_t rejectedPulses() const { return rejected_; }  // pulses outside kRcMinUs..kRcMaxUs
  uint32_t badFrames() const { return bad_frames_; }     // PPM frames not flown

 private:
  bool ppmEdge(const RcEdge& e);
  bool pwmEdge(const RcEdge& e);
  bool valid(uint16_t us);
  bool countHolds(uint8_t channels);

  RcProtocol protocol_ = RcProtocol::kOff;
  uint8_t pwm_channels_ = kRcMinChannels;
  uint8_t last_pins_ = 0;
  bool have_pins_ = false;       // last_pins_ is known (the first edge after a gap tells)
  bool resume_ = false;          // PPM: after a silence, the next falling edge starts a frame
  uint8_t new_count_ = 0;        // PPM: a channel count other than the last valid frame's, seen once
  bool have_last_ = false;
  uint16_t last_ticks_ = 0;      // PPM: the last falling edge
  int8_t index_ = -1;            // PPM: the channel being timed; -1: waiting for a sync gap
  bool frame_bad_ = false;       // PPM: this frame had a bad pulse
  uint16_t rise_ticks_[kRcMaxChannels] = {};  // PWM: each pin's rising edge
  uint8_t rising_ = 0;           // PWM: pins whose rising edge was seen
  uint8_t fresh_ = 0;            // PWM: channels with a new pulse since the last frame
  RcFrame building_;
  RcFrame frame_;
  uint32_t frames_ = 0, rejected_ = 0, bad_frames_ = 0;
};

// ---- sticks ----

// Which channel carries what (fly's parameters point at it). `map` is the order of the first
// four channels as the transmitter sends them, a permutation of "AETR" (A aileron = roll,
// E elevator = pitch, T throttle, R rudder = yaw): AETR (FrSky, Futaba), TAER (Spektrum, JR)...
struct RcSettings {
  RcProtocol protocol = RcProtocol::kOff;
  uint8_t pwm_channels = 5;      // PWM: pins wired, from A8
  char map[5] = {'A', 'E', 'T', 'R', '\0'};
  uint8_t mode_channel = 4;      // 0-based: channel 5 low = angle mode, high = rate mode; 0xFF none
  FlightMode default_mode = FlightMode::kAngle;  // without a mode channel in the frame
};
// Whether `text` is a permutation of A, E, T and R (case-insensitive); `out` the upper-case one.
bool parseRcMap(const char* text, char (&out)[5]);
// The channel (0-based) that carries `function` ('A', 'E', 'T' or 'R') in `map`.
uint8_t rcChannelOf(const char (&map)[5], char function);

// What the sticks ask for (fly's parameters point at it).
struct StickSettings {
  uint8_t max_angle_deg = 30;     // angle mode: full roll or pitch stick
  uint16_t max_rate_dps = 200;    // rate mode: full roll or pitch stick
  uint16_t max_yaw_rate_dps = 100;
};

constexpr uint16_t kStickCentreUs = 1500;
constexpr uint16_t kStickDeadbandUs = 10;   // around the centre: 0
constexpr uint16_t kStickLowUs = 1100;      // throttle low, yaw full left
constexpr uint16_t kStickHighUs = 1900;     // yaw full right
constexpr uint16_t kStickHoldMs = 1000;     // an arming or disarming gesture held this long

// A frame's sticks, mapped: deflections in us from the centre (+-500, deadband taken out),
// the throttle as sent, the mode switch.
struct Sticks {
  int16_t roll = 0;   // + right (right side down)
  int16_t pitch = 0;  // + forward (nose down)
  int16_t yaw = 0;    // + right (nose right)
  uint16_t throttle_us = 1000;
  FlightMode mode = FlightMode::kAngle;
};
Sticks sticksOf(const RcFrame& frame, const RcSettings& settings);

enum class StickGesture : uint8_t { kNone, kArm, kDisarm };
// Throttle low and yaw full right: arm; throttle low and yaw full left: disarm.
StickGesture stickGesture(const Sticks& s);

// The sticks as a setpoint in the frame path's units, integer, with gains made when the
// settings change: roll and pitch angles (angle mode) or rates (rate mode), the yaw rate, and
// the throttle's share of the motors' range in 1/1024.
class StickCommand {
 public:
  StickCommand() { setSettings(StickSettings()); }
  void setSettings(const StickSettings& s);
  const StickSettings& settings() const { return settings_; }
  SetpointQ setpoint(const Sticks& s) const;
  static int32_t throttleShareQ10(uint16_t throttle_us);  // 0..1024 over 1000..2000 us

 private:
  StickSettings settings_;
  Gain angle_per_us_, rate_per_us_, yaw_per_us_;
};

}  // namespace fly

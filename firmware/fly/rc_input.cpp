// The RC receiver, decoded (rc_input.hpp).
#include "rc_input.hpp"

namespace fly {

namespace {
constexpr uint8_t kPpmBit = 0x01;  // A8: bit 0 of the watched pins
uint16_t usOf(uint16_t from_ticks, uint16_t to_ticks) {
  return static_cast<uint16_t>(static_cast<uint16_t>(to_ticks - from_ticks) >> 1);  // 0.5 us ticks
}
}  // namespace

void RcDecoder::begin(RcProtocol protocol, uint8_t pwm_channels) {
  protocol_ = protocol;
  pwm_channels_ = pwm_channels < kRcMinChannels ? kRcMinChannels
                  : pwm_channels > kRcMaxChannels ? kRcMaxChannels
                                                  : pwm_channels;
  frame_ = RcFrame();
  gap();
}

void RcDecoder::silence() {
  gap();
  resume_ = protocol_ == RcProtocol::kPpm && frame_.channels != 0;
}

void RcDecoder::gap() {
  resume_ = false;
  have_pins_ = false;
  have_last_ = false;
  index_ = -1;
  frame_bad_ = false;
  rising_ = 0;
  fresh_ = 0;
  building_ = RcFrame();
}

// A receiver sends every frame with the same number of channels; a frame with another count is
// noise (a spike that split a channel in two halves both long enough, a line back in the middle
// of a frame) unless the next frame has that count too (the receiver was set up anew).
bool RcDecoder::countHolds(uint8_t channels) {
  if (frame_.channels == 0 || channels == frame_.channels) {
    new_count_ = 0;
    return true;
  }
  const bool again = channels == new_count_;
  new_count_ = again ? 0 : channels;
  return again;
}

bool RcDecoder::valid(uint16_t us) {
  if (us >= kRcMinUs && us <= kRcMaxUs) return true;
  ++rejected_;
  return false;
}

bool RcDecoder::edge(const RcEdge& e) {
  if (!have_pins_) {  // the levels before this edge are unknown: it tells them
    have_pins_ = true;
    last_pins_ = e.pins;
    if (!resume_) return false;
    last_pins_ = static_cast<uint8_t>(e.pins ^ kPpmBit);  // after a silence: the PPM pin changed
  }
  bool done = false;
  if (protocol_ == RcProtocol::kPpm) done = ppmEdge(e);
  if (protocol_ == RcProtocol::kPwm) done = pwmEdge(e);
  last_pins_ = e.pins;
  return done;
}

// Falling edges of the PPM pin: the interval since the last one is a channel, or the sync gap
// that ends the frame (valid with kRcMinChannels.. kRcMaxChannels good channels).
bool RcDecoder::ppmEdge(const RcEdge& e) {
  const bool falling = (last_pins_ & kPpmBit) && !(e.pins & kPpmBit);
  if (!falling) return false;
  if (!have_last_) {
    have_last_ = true;
    last_ticks_ = e.ticks;
    if (resume_) index_ = 0;  // the silence before it was a sync gap
    resume_ = false;
    return false;
  }
  const uint16_t us = usOf(last_ticks_, e.ticks);
  last_ticks_ = e.ticks;
  if (us >= kRcSyncMinUs) {
    const int8_t channels = index_;
    const bool was_bad = frame_bad_;
    index_ = 0;
    frame_bad_ = false;
    if (channels < 0) return false;  // the first gap: frames start here
    const bool too_few = channels < static_cast<int8_t>(kRcMinChannels);
    if (was_bad || too_few || !countHolds(static_cast<uint8_t>(channels))) {
      ++bad_frames_;
      return false;
    }
    building_.channels = static_cast<uint8_t>(channels);
    frame_ = building_;
    ++frames_;
    return true;
  }
  if (index_ < 0) return false;  // waiting for the first gap
  if (index_ >= static_cast<int8_t>(kRcMaxChannels)) {
    frame_bad_ = true;  // more channels than a frame has: noise between them
    return false;
  }
  if (!valid(us)) frame_bad_ = true;
  building_.us[index_] = us;
  ++index_;
  return false;
}

// Each pin on its own: rising edge, falling edge, the width between; a frame once every wired
// channel has a new valid pulse.
bool RcDecoder::pwmEdge(const RcEdge& e) {
  const uint8_t changed = static_cast<uint8_t>(e.pins ^ last_pins_);
  bool done = false;
  for (uint8_t i = 0; i < pwm_channels_; ++i) {
    const uint8_t bit = static_cast<uint8_t>(1u << i);
    if (!(changed & bit)) continue;
    if (e.pins & bit) {  // rising
      rise_ticks_[i] = e.ticks;
      rising_ |= bit;
      continue;
    }
    if (!(rising_ & bit)) continue;  // a falling edge without its rising one (after a gap)
    rising_ &= static_cast<uint8_t>(~bit);
    const uint16_t us = usOf(rise_ticks_[i], e.ticks);
    if (!valid(us)) continue;
    building_.us[i] = us;
    fresh_ |= bit;
    const uint8_t all = static_cast<uint8_t>((1u << pwm_channels_) - 1u);
    if (fresh_ == all) {
      building_.channels = pwm_channels_;
      frame_ = building_;
      fresh_ = 0;
      ++frames_;
      done = true;
    }
  }
  return done;
}

// ---- sticks ----

bool parseRcMap(const char* text, char (&out)[5]) {
  uint8_t seen = 0;
  char map[5] = {};
  for (uint8_t i = 0; i < 4; ++i) {
    char c = text[i];
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
    const uint8_t bit = c == 'A' ? 1 : c == 'E' ? 2 : c == 'T' ? 4 : c == 'R' ? 8 : 0;
    if (bit == 0 || (seen & bit)) return false;
    seen |= bit;
    map[i] = c;
  }
  if (text[4] != '\0') return false;
  for (uint8_t i = 0; i < 5; ++i) out[i] = map[i];
  return true;
}

uint8_t rcChannelOf(const char (&map)[5], char function) {
  for (uint8_t i = 0; i < 4; ++i) {
    if (map[i] == function) return i;
  }
  return 0;
}

namespace {
int16_t deflection(uint16_t us) {
  int32_t d = static_cast<int32_t>(us) - kStickCentreUs;
  if (d > -static_cast<int32_t>(kStickDeadbandUs) && d < kStickDeadbandUs) return 0;
  d += d > 0 ? -static_cast<int32_t>(kStickDeadbandUs) : kStickDeadbandUs;
  const int32_t full = 500 - kStickDeadbandUs;
  return static_cast<int16_t>(d > full ? full : (d < -full ? -full : d));
}
}  // namespace

Sticks sticksOf(const RcFrame& f, const RcSettings& s) {
  Sticks out;
  out.roll = deflection(f.us[rcChannelOf(s.map, 'A')]);
  out.pitch = deflection(f.us[rcChannelOf(s.map, 'E')]);
  out.yaw = deflection(f.us[rcChannelOf(s.map, 'R')]);
  out.throttle_us = f.us[rcChannelOf(s.map, 'T')];
  out.mode = s.default_mode;
  if (s.mode_channel < f.channels) out.mode = f.us[s.mode_channel] > kStickCentreUs ? FlightMode::kRate : FlightMode::kAngle;
  return out;
}

StickGesture stickGesture(const Sticks& s) {
  if (s.throttle_us >= kStickLowUs) return StickGesture::kNone;
  const int16_t full = static_cast<int16_t>(kStickHighUs - kStickCentreUs - kStickDeadbandUs);
  if (s.yaw >= full) return StickGesture::kArm;
  if (s.yaw <= -full) return StickGesture::kDisarm;
  return StickGesture::kNone;
}

void StickCommand::setSettings(const StickSettings& s) {
  settings_ = s;
  const float full_us = 500.0f - kStickDeadbandUs;
  angle_per_us_ = gainOf(s.max_angle_deg * kRadPerDeg / kRadPerAngleUnit / full_us);
  rate_per_us_ = gainOf(s.max_rate_dps * kRadPerDeg / kRadPerRateUnit / full_us);
  yaw_per_us_ = gainOf(s.max_yaw_rate_dps * kRadPerDeg / kRadPerRateUnit / full_us);
}

// Roll right and pitch forward are positive roll and pitch; yaw right is nose right, a negative
// yaw rate (flight_types.hpp's axes).
SetpointQ StickCommand::setpoint(const Sticks& s) const {
  SetpointQ q;
  q.mode = s.mode;
  if (s.mode == FlightMode::kAngle) {
    q.roll = applyGain(s.roll, angle_per_us_);
    q.pitch = applyGain(s.pitch, angle_per_us_);
  } else {
    q.rate[0] = applyGain(s.roll, rate_per_us_);
    q.rate[1] = applyGain(s.pitch, rate_per_us_);
  }
  q.rate[2] = -applyGain(s.yaw, yaw_per_us_);
  return q;
}

int32_t StickCommand::throttleShareQ10(uint16_t throttle_us) {
  if (throttle_us <= 1000) return 0;
  if (throttle_us >= 2000) return 1024;
  return ((static_cast<int32_t>(throttle_us) - 1000) * 1049) >> 10;  // 1.024 per us, 0..1023
}

}  // namespace fly

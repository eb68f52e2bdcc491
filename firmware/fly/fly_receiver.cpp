// fly's receiver (fly_app.hpp): the edges hal::Rc queued, decoded into frames (rc_input.hpp),
// the frames into sticks; stick arming and disarming (held kStickHoldMs, arming behind every
// check `arm` has), and while the sticks fly, their setpoint and throttle. The receiver's
// failsafe (no valid frame for kRcLossMs) is in checkFailsafes (fly_app.cpp); its commands are
// here, their table rows in commands.cpp.
#include "fly_app.hpp"
#include "fly_view.hpp"
#include "params.hpp"  // kRcMapWords: the maps `rcmap` offers (the usual transmitters' orders, MultiWii's list)

namespace fly {

void FlyApp::pollReceiver(uint32_t now_ms) {
  if (rc_settings_.protocol == RcProtocol::kOff) return;
  if (now_ms - receiver_.last_edge_ms > kRcEdgeGapMs) rc_.silence();  // the ticks may have wrapped
  const uint16_t lost = hal::Rc::lostEdges();
  if (lost != receiver_.lost_edges) {  // edges missing: whatever was being timed is noise
    receiver_.lost_edges = lost;
    rc_.gap();
  }
  hal::Rc::Edge e;
  bool any = false;
  while (hal::Rc::nextEdge(e)) {
    any = true;
    if (rc_.edge({e.pins, e.ticks})) onReceiverFrame(now_ms);
  }
  if (any) receiver_.last_edge_ms = now_ms;
}

void FlyApp::onReceiverFrame(uint32_t now_ms) {
  receiver_.seen = true;
  receiver_.last_frame_ms = now_ms;
  const FlightMode before = receiver_.sticks.mode;
  receiver_.sticks = sticksOf(rc_.frame(), rc_settings_);
  stickGestures(now_ms);
  if (!flight_.armed || flight_.source != ArmSource::kSticks) return;
  if (receiver_.sticks.mode != before) controller_.reset();  // angle <-> rate: integrators afresh
  flyTheSticks();
}

// A gesture counts once it has been held kStickHoldMs in every frame; it acts once per hold.
void FlyApp::stickGestures(uint32_t now_ms) {
  const StickGesture g = stickGesture(receiver_.sticks);
  if (g != receiver_.gesture) {
    receiver_.gesture = g;
    receiver_.gesture_ms = now_ms;
    receiver_.gesture_used = false;
    return;
  }
  if (g == StickGesture::kNone || receiver_.gesture_used || now_ms - receiver_.gesture_ms < kStickHoldMs) return;
  receiver_.gesture_used = true;
  if (g == StickGesture::kDisarm) {
    if (flight_.armed) disarm(DisarmCause::kSticks);
    return;
  }
  if (flight_.armed) return;
  receiver_.refused = arm(ArmSource::kSticks);
  notes_ |= kNoteStickArm;
}

// The sticks' setpoint and throttle, for the frames that follow.
void FlyApp::flyTheSticks() {
  command_.setpoint_q = stick_command_.setpoint(receiver_.sticks);
  command_.setpoint = setpointOf(command_.setpoint_q);
  updateOutputLimits();
}

// ---- commands ----

void FlyApp::cmdRc(RcProtocol protocol, uint8_t pwm_channels) {
  if (refuseWhileArmed()) return;
  rc_settings_.protocol = protocol;
  if (protocol == RcProtocol::kPwm) rc_settings_.pwm_channels = pwm_channels;
  applyReceiverSettings();
  view::receiver(*this);
}

void FlyApp::applyReceiverSettings() {
  const RcSettings& s = rc_settings_;
  rc_.begin(s.protocol, s.pwm_channels);
  receiver_ = ReceiverState();
  const uint8_t mask = s.protocol == RcProtocol::kPpm   ? static_cast<uint8_t>(1u << hal::kRcPins.ppm_bit)
                       : s.protocol == RcProtocol::kPwm ? static_cast<uint8_t>((1u << s.pwm_channels) - 1u)
                                                        : 0;
  hal::Rc::init(mask);
  receiver_.lost_edges = hal::Rc::lostEdges();
}

void FlyApp::cmdRcMap(uint8_t which) {
  if (refuseWhileArmed()) return;
  tc::flashWordCopy(kRcMapWords, which, rc_settings_.map, sizeof rc_settings_.map);  // params.hpp's words
  view::receiver(*this);
}

void FlyApp::cmdRates(uint8_t angle_deg, uint16_t rate_dps, uint16_t yaw_dps) {
  if (refuseWhileArmed()) return;
  StickSettings s;
  s.max_angle_deg = angle_deg;
  s.max_rate_dps = rate_dps;
  s.max_yaw_rate_dps = yaw_dps;
  stick_command_.setSettings(s);
  view::receiver(*this);
}

// Disarmed only, like every setting that could make the motors jump (params.hpp): switching the
// law from angle to rate steps the torque unless the vehicle is level and still.
void FlyApp::cmdFlightMode(FlightMode mode) {
  if (refuseWhileArmed()) return;
  rc_settings_.default_mode = mode;
  view::receiver(*this);
}

}  // namespace fly

// The lift-off test rig: a quadrocopter frame tied to the floor by four ropes, one under each
// motor, with four actuators sharing one power source and no attitude controller.
//
// Body axes: x forward, y left, z up. Motor i sits at azimuth 45 + 90 i degrees, arm_m from the
// centre: 0 front-left (+x,+y), 1 rear-left (-x,+y), 2 rear-right (-x,-y), 3 front-right
// (+x,-y). Motors 0 and 2 spin counter-clockwise seen from above, 1 and 3 clockwise, so the
// drag torques cancel when the four are equal.
//
// Rigid body with three degrees of freedom: height z of the centre, roll phi (about x), pitch
// theta (about y); corner heights z_i = z + y_i sin(phi) - x_i sin(theta). Forces at corner i:
// thrust (along body z; its vertical part thrust cos(tilt)), rope tension when z_i exceeds
// rope_len_m (one-sided spring + damper), floor contact when z_i < 0 (one-sided spring +
// damper). Gravity at the centre; aerodynamic damping on the rates. Moments:
//   roll  M_x =  sum y_i F_i,   pitch M_y = -sum x_i F_i,   yaw M_z = sum -spin_i Q_i.
// Four equal thrusts stay level; a weaker motor's corner sinks: the frame tilts toward it.
// Integrated with semi-implicit Euler in internal sub-steps of at most 1 ms.
#pragma once
#include <array>
#include "plant/actuator.hpp"
#include "plant/power_source.hpp"

namespace plant {

struct QuadFrameParams {
  double mass_kg = 1.0;            // whole aircraft: frame, battery, board, motors
  double arm_m = 0.225;            // centre to motor axis (450 mm frame)
  double inertia_kgm2 = 0.0;       // roll = pitch inertia; 0: 0.6 * mass * arm^2 / 2 (estimate)
  double rope_len_m = 0.10;        // floor anchor to corner when taut
  double rope_stiffness_n_per_m = 2000.0;
  double rope_damping_ns_per_m = 20.0;
  double floor_stiffness_n_per_m = 20000.0;
  double floor_damping_ns_per_m = 100.0;
  double height_damping_ns_per_m = 0.5;    // air
  double tilt_damping_nms_per_rad = 0.05;  // air, props
  BatteryParams power;             // default: full 3S LiPo
  Environment env;
};

struct QuadState {
  double t_s = 0.0;
  std::array<double, 4> thrust_g{};
  std::array<double, 4> rpm{};
  std::array<double, 4> corner_height_m{};
  double height_m = 0.0;
  double roll_deg = 0.0;
  double pitch_deg = 0.0;
  double tilt_deg = 0.0;         // angle between body z and vertical
  double roll_moment_nm = 0.0;   // from thrust differences only
  double pitch_moment_nm = 0.0;
  double yaw_moment_nm = 0.0;    // from propeller drag torques
  double bus_v = 0.0;
  double bus_current_a = 0.0;
};

class QuadFrame {
 public:
  QuadFrame(const QuadFrameParams& params, const std::array<ActuatorParams, 4>& motors);

  void setPulse(int motor, double pulse_us, double t_s) { act_[motor].setPulse(pulse_us, t_s); }
  void holdPulse(int motor, double pulse_us) { act_[motor].holdPulse(pulse_us); }
  void step(double dt_s);
  void run(double duration_s, double dt_s = 0.001);
  double time_s() const { return t_s_; }

  QuadState state() const;
  double busVoltage_v() const { return bus_v_; }
  // Largest tilt since construction (a frame with unequal motors lifts off crooked: the weak
  // corner stays down while the others rise, until all four ropes are taut).
  double maxTilt_deg() const { return max_tilt_deg_; }
  // Corner i position in body axes (x, y), metres.
  double motorX_m(int motor) const { return pos_x_[motor]; }
  double motorY_m(int motor) const { return pos_y_[motor]; }
  static int spinDirection(int motor) { return (motor % 2 == 0) ? 1 : -1; }  // +1 = CCW

  Actuator& actuator(int motor) { return act_[motor]; }
  const Actuator& actuator(int motor) const { return act_[motor]; }
  PowerSource& power() { return power_; }
  const QuadFrameParams& params() const { return p_; }

 private:
  void substep(double dt_s);

  QuadFrameParams p_;
  std::array<Actuator, 4> act_;
  PowerSource power_;
  std::array<double, 4> pos_x_{}, pos_y_{};
  double inertia_ = 0.0;
  double t_s_ = 0.0;
  double z_ = 0.0, vz_ = 0.0, roll_ = 0.0, roll_rate_ = 0.0, pitch_ = 0.0, pitch_rate_ = 0.0;
  double bus_v_ = 0.0, bus_current_a_ = 0.0;
  double max_tilt_deg_ = 0.0;
  double min_cos_tilt_ = 1.0;
};

}  // namespace plant

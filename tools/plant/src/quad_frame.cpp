#include "plant/quad_frame.hpp"
#include "plant/angles.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace plant {

namespace {
constexpr double kMaxSubstep_s = 0.001;
}  // namespace

QuadFrame::QuadFrame(const QuadFrameParams& params, const std::array<ActuatorParams, 4>& motors)
    : p_(params),
      act_{Actuator(motors[0], params.env), Actuator(motors[1], params.env),
           Actuator(motors[2], params.env), Actuator(motors[3], params.env)},
      power_(params.power) {
  const double c = p_.arm_m / std::numbers::sqrt2;
  const double sx[4] = {1, -1, -1, 1}, sy[4] = {1, 1, -1, -1};
  for (int i = 0; i < 4; ++i) {
    pos_x_[i] = sx[i] * c;
    pos_y_[i] = sy[i] * c;
  }
  inertia_ = p_.inertia_kgm2 > 0.0 ? p_.inertia_kgm2 : 0.6 * p_.mass_kg * p_.arm_m * p_.arm_m / 2.0;
  // Resting on the floor: the four contact springs carry the weight.
  z_ = -p_.mass_kg * kGravity_m_per_s2 / (4.0 * p_.floor_stiffness_n_per_m);
  BusLoad load;
  for (const Actuator& a : act_) load += a.busLoad();
  bus_v_ = power_.solveBusVoltage(load);
}

void QuadFrame::step(double dt_s) {
  int n = static_cast<int>(std::ceil(dt_s / kMaxSubstep_s - 1e-9));
  n = std::max(n, 1);
  const double h = dt_s / n;
  for (int i = 0; i < n; ++i) substep(h);
}

void QuadFrame::run(double duration_s, double dt_s) {
  const double end = t_s_ + duration_s - 0.5 * dt_s;
  while (t_s_ < end) step(dt_s);
}

void QuadFrame::substep(double h) {
  BusLoad load;
  for (const Actuator& a : act_) load += a.busLoad();
  bus_v_ = power_.solveBusVoltage(load);
  bus_current_a_ = 0.0;
  for (Actuator& a : act_) bus_current_a_ += a.step(h, bus_v_);
  power_.step(h, bus_current_a_);
  t_s_ += h;

  const double cr = std::cos(roll_), sr = std::sin(roll_);
  const double cp = std::cos(pitch_), sp = std::sin(pitch_);
  double fz = 0.0, mx = 0.0, my = 0.0;
  for (int i = 0; i < 4; ++i) {
    const double x = pos_x_[i], y = pos_y_[i];
    const double zi = z_ + y * sr - x * sp;
    const double vzi = vz_ + y * cr * roll_rate_ - x * cp * pitch_rate_;
    double f = act_[i].thrust_n() * cr * cp;
    if (zi > p_.rope_len_m) {
      f -= std::max(0.0, p_.rope_stiffness_n_per_m * (zi - p_.rope_len_m) +
                             p_.rope_damping_ns_per_m * vzi);
    }
    if (zi < 0.0) {
      f += std::max(0.0, -p_.floor_stiffness_n_per_m * zi - p_.floor_damping_ns_per_m * vzi);
    }
    fz += f;
    mx += y * f;
    my -= x * f;
  }
  const double m = p_.mass_kg;
  const double az = (fz - m * kGravity_m_per_s2 - p_.height_damping_ns_per_m * vz_) / m;
  const double aroll = (mx - p_.tilt_damping_nms_per_rad * roll_rate_) / inertia_;
  const double apitch = (my - p_.tilt_damping_nms_per_rad * pitch_rate_) / inertia_;
  vz_ += h * az;
  roll_rate_ += h * aroll;
  pitch_rate_ += h * apitch;
  z_ += h * vz_;
  roll_ += h * roll_rate_;
  pitch_ += h * pitch_rate_;
  const double cos_tilt = std::cos(roll_) * std::cos(pitch_);
  if (cos_tilt < min_cos_tilt_) {
    min_cos_tilt_ = cos_tilt;
    max_tilt_deg_ = std::acos(std::clamp(cos_tilt, -1.0, 1.0)) * kRadToDeg;
  }
}

QuadState QuadFrame::state() const {
  QuadState s;
  s.t_s = t_s_;
  const double sr = std::sin(roll_), sp = std::sin(pitch_);
  for (int i = 0; i < 4; ++i) {
    s.thrust_g[i] = act_[i].thrust_g();
    s.rpm[i] = act_[i].rpm();
    s.corner_height_m[i] = z_ + pos_y_[i] * sr - pos_x_[i] * sp;
    const double f = act_[i].thrust_n();
    s.roll_moment_nm += pos_y_[i] * f;
    s.pitch_moment_nm -= pos_x_[i] * f;
    s.yaw_moment_nm -= spinDirection(i) * act_[i].torque_nm();
  }
  s.height_m = z_;
  s.roll_deg = roll_ * kRadToDeg;
  s.pitch_deg = pitch_ * kRadToDeg;
  s.tilt_deg = std::acos(std::clamp(std::cos(roll_) * std::cos(pitch_), -1.0, 1.0)) * kRadToDeg;
  s.bus_v = bus_v_;
  s.bus_current_a = bus_current_a_;
  return s;
}

}  // namespace plant

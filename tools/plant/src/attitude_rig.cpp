#include "plant/attitude_rig.hpp"
#include "plant/angles.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace plant {

namespace {
constexpr double kVibrationRefRadS = 10000.0 * 2.0 * std::numbers::pi / 60.0;

std::array<double, 3> cross(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// World z (up) seen in body axes: the third row of the rotation matrix of q.
std::array<double, 3> upInBody(const std::array<double, 4>& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
}
}  // namespace

std::array<double, 3> eulerDeg(const std::array<double, 4>& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double roll = std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  const double pitch = std::asin(std::clamp(2 * (w * y - z * x), -1.0, 1.0));
  const double yaw = std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
  return {roll * kRadToDeg, pitch * kRadToDeg, yaw * kRadToDeg};
}

AttitudeRig::AttitudeRig(const RigCommon& common, const std::vector<ActuatorParams>& motors,
                         const std::vector<MotorMount>& mounts)
    : common_(common), mounts_(mounts), power_(common.power) {
  if (motors.size() != mounts.size() || motors.empty())
    throw std::invalid_argument("an attitude rig needs one mount per motor, and at least one motor");
  if (!common.spin.empty()) {
    if (common.spin.size() != mounts.size())
      throw std::invalid_argument("the rig has " + std::to_string(mounts.size()) + " motors: give one spin per motor, not " +
                                  std::to_string(common.spin.size()));
    for (std::size_t i = 0; i < mounts_.size(); ++i) {
      if (common.spin[i] != 1 && common.spin[i] != -1)
        throw std::invalid_argument("a motor's spin is +1 (counter-clockwise from above) or -1 (clockwise)");
      mounts_[i].spin = common.spin[i];
    }
  }
  for (const ActuatorParams& p : motors) act_.emplace_back(p, common.env);
  dead_.assign(act_.size(), false);
  rotor_angle_rad_.assign(act_.size(), 0.0);
  BusLoad load;
  for (const Actuator& a : act_) load += a.busLoad();
  bus_v_ = power_.solveBusVoltage(load);
}

void AttitudeRig::setPulse(int motor, double pulse_us, double t_s) {
  if (!dead_.at(motor)) act_.at(motor).setPulse(pulse_us, t_s);
}

void AttitudeRig::holdPulse(int motor, double pulse_us) {
  if (!dead_.at(motor)) act_.at(motor).holdPulse(pulse_us);
}

void AttitudeRig::killMotor(int motor) {
  dead_.at(motor) = true;
  act_.at(motor).holdPulse(0.0);  // duty 0 for good: no drive, no time-out, no re-arming
}

void AttitudeRig::loseThrust(int motor, double share) { act_.at(motor).damagePropeller(share); }

void AttitudeRig::step(double dt_s) {
  const int n = std::max(1, static_cast<int>(std::ceil(dt_s / kMaxSubstep_s - 1e-9)));
  const double h = dt_s / n;
  for (int i = 0; i < n; ++i) substep(h);
}

void AttitudeRig::substep(double h) {
  BusLoad load;
  for (const Actuator& a : act_) load += a.busLoad();
  bus_v_ = power_.solveBusVoltage(load);
  bus_current_a_ = 0.0;
  std::array<double, 3> torque{};
  double momentum = 0.0;
  for (std::size_t i = 0; i < act_.size(); ++i) {
    Actuator& a = act_[i];
    const double w0 = a.omega_rad_per_s();
    bus_current_a_ += a.step(h, bus_v_);
    const double w1 = a.omega_rad_per_s();
    const MotorMount& m = mounts_[i];
    const double f = a.thrust_n();
    const double j = a.params().inertia_kgm2();
    torque[0] += m.y_m * f;
    torque[1] -= m.x_m * f;
    if (common_.reaction_torque) torque[2] -= m.spin * (a.torque_nm() + j * (w1 - w0) / h);
    momentum += m.spin * j * w1;
    rotor_angle_rad_[i] = std::fmod(rotor_angle_rad_[i] + w1 * h, 2.0 * std::numbers::pi);
  }
  power_.step(h, bus_current_a_);
  torque_nm_ = torque;
  for (int k = 0; k < 3; ++k) torque[k] += disturbance_nm_[k];
  integrate(h, torque, momentum);
  t_s_ += h;
}

RigTruth AttitudeRig::truth() const {
  const BodyState b = body();
  RigTruth t;
  t.t_s = t_s_;
  t.q_wxyz = b.q_wxyz;
  const auto e = eulerDeg(b.q_wxyz);
  t.roll_deg = e[0];
  t.pitch_deg = e[1];
  t.yaw_deg = e[2];
  for (int i = 0; i < 3; ++i) {
    t.rate_dps[i] = b.rate_rad_s[i] * kRadToDeg;
    t.accel_dps2[i] = b.accel_rad_s2[i] * kRadToDeg;
  }
  t.motor_torque_nm = torque_nm_;
  // Specific force at r: a - g = alpha x r + w x (w x r) + g up (the pivot does not move).
  const auto& r = common_.imu_mount_m;
  const auto a1 = cross(b.accel_rad_s2, r);
  const auto a2 = cross(b.rate_rad_s, cross(b.rate_rad_s, r));
  const auto up = upInBody(b.q_wxyz);
  for (int i = 0; i < 3; ++i)
    t.specific_force_g[i] = (a1[i] + a2[i]) / kGravity_m_per_s2 + up[i];
  if (common_.vibration_g_at_10krpm > 0.0) {
    for (std::size_t m = 0; m < act_.size(); ++m) {
      const double s = act_[m].omega_rad_per_s() / kVibrationRefRadS;
      const double amp = common_.vibration_g_at_10krpm * s * s;
      t.specific_force_g[0] += amp * std::cos(rotor_angle_rad_[m]);
      t.specific_force_g[1] += amp * std::sin(rotor_angle_rad_[m]);
    }
  }
  return t;
}

}  // namespace plant

#include "plant/gimbal.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>

namespace plant {

namespace {

using Vec3 = Eigen::Vector3d;

std::vector<MotorMount> asVector(const std::array<MotorMount, 4>& m) { return {m.begin(), m.end()}; }

Vec3 vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

}  // namespace

const char* layoutName(Layout layout) { return layout == Layout::kPlus ? "plus" : "X"; }

std::array<MotorMount, 4> quadMounts(Layout layout, double arm_m) {
  if (layout == Layout::kPlus)
    return {{{arm_m, 0.0, 1}, {0.0, arm_m, -1}, {-arm_m, 0.0, 1}, {0.0, -arm_m, -1}}};
  const double c = arm_m / std::numbers::sqrt2;
  return {{{c, c, 1}, {-c, c, -1}, {-c, -c, 1}, {c, -c, -1}}};
}

Gimbal::Gimbal(const GimbalParams& params, const std::array<ActuatorParams, 4>& motors)
    : AttitudeRig(params.common, {motors.begin(), motors.end()}, asVector(quadMounts(params.layout, params.arm_m))),
      p_(params) {}

void Gimbal::setState(const std::array<double, 4>& q_wxyz, const std::array<double, 3>& rate_rad_s) {
  Eigen::Quaterniond q(q_wxyz[0], q_wxyz[1], q_wxyz[2], q_wxyz[3]);
  q.normalize();
  q_ = {q.w(), q.x(), q.y(), q.z()};
  w_ = rate_rad_s;
  w_dot_ = {};
}

void Gimbal::integrate(double h, const std::array<double, 3>& torque_nm, double rotor_momentum_nms) {
  const Eigen::Quaterniond q(q_[0], q_[1], q_[2], q_[3]);
  const Vec3 inertia = vec(p_.inertia_kgm2);
  const Vec3 damping = vec(p_.damping_nms_per_rad);
  const Vec3 h_rotors(0.0, 0.0, rotor_momentum_nms);
  // Gravity on a centre of gravity d below the pivot: r x F with r = (0, 0, -d) in the body.
  const Vec3 weight_body = q.conjugate() * Vec3(0.0, 0.0, -p_.mass_kg * kGravity_m_per_s2);
  const Vec3 tau = vec(torque_nm) + Vec3(0.0, 0.0, -p_.cg_below_pivot_m).cross(weight_body);
  auto accel = [&](const Vec3& w) -> Vec3 {
    const Vec3 gyro = w.cross(inertia.cwiseProduct(w) + h_rotors);
    return (tau - gyro - damping.cwiseProduct(w)).cwiseQuotient(inertia);
  };
  const Vec3 w0 = vec(w_);
  const Vec3 k1 = accel(w0);
  const Vec3 k2 = accel(w0 + 0.5 * h * k1);
  const Vec3 k3 = accel(w0 + 0.5 * h * k2);
  const Vec3 k4 = accel(w0 + h * k3);
  const Vec3 w1 = w0 + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  // The rotation of the sub-step at its mean rate (exact for a constant rate).
  const Vec3 turn = 0.5 * (w0 + w1) * h;
  const double angle = turn.norm();
  Eigen::Quaterniond dq = Eigen::Quaterniond::Identity();
  if (angle > 0.0) dq = Eigen::Quaterniond(Eigen::AngleAxisd(angle, turn / angle));
  const Eigen::Quaterniond q1 = (q * dq).normalized();
  q_ = {q1.w(), q1.x(), q1.y(), q1.z()};
  w_ = {w1.x(), w1.y(), w1.z()};
  const Vec3 wd = accel(w1);
  w_dot_ = {wd.x(), wd.y(), wd.z()};
}

BodyState Gimbal::body() const {
  BodyState b;
  b.q_wxyz = q_;
  b.rate_rad_s = w_;
  b.accel_rad_s2 = w_dot_;
  return b;
}

}  // namespace plant

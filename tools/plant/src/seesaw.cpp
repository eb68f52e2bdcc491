#include "plant/seesaw.hpp"
#include "plant/angles.hpp"

#include <cmath>
#include <limits>
#include <numbers>

namespace plant {

namespace {

std::vector<MotorMount> seesawMounts(double arm_m) { return {{0.0, arm_m, 1}, {0.0, -arm_m, -1}}; }

RigCommon withImuOnTheBoard(RigCommon c) {
  c.imu_mount_m = {0.0, 0.0, 0.03};
  return c;
}
}  // namespace

SeesawParams SeesawParams::benchRig() {
  SeesawParams p;
  const double beam_kg = 0.120, beam_m = 0.50;
  p.parts = {
      {"beam (aluminium tube 0.5 m)", beam_kg, 0.0, 0.0, beam_kg * beam_m * beam_m / 12.0},
      {"flight board + IMU", 0.045, 0.0, 0.03, 0.0},
      {"ballast", 0.200, 0.0, -0.10, 0.0},
  };
  p.common = withImuOnTheBoard(p.common);
  return p;
}

Seesaw::Seesaw(const SeesawParams& params, const std::array<ActuatorParams, 2>& motors)
    : AttitudeRig(params.common, {motors[0], motors[1]}, seesawMounts(params.arm_m)), p_(params) {
  all_parts_ = p_.parts;
  const double side[2] = {p_.arm_m, -p_.arm_m};
  for (int i = 0; i < 2; ++i) {
    const std::string which = i == 0 ? " 0 (left)" : " 1 (right)";
    all_parts_.push_back({"motor" + which, motors[i].motor.mass_g / 1000.0, side[i], p_.motor_height_m, 0.0});
    all_parts_.push_back({"propeller" + which, motors[i].prop.mass_g / 1000.0, side[i], p_.prop_height_m, 0.0});
  }
  for (const RigPart& part : all_parts_) {
    inertia_ += part.mass_kg * (part.y_m * part.y_m + part.z_m * part.z_m) + part.own_inertia_kgm2;
    s_y_ += part.mass_kg * part.y_m;
    s_z_ += part.mass_kg * part.z_m;
  }
}

void Seesaw::setAngle(double theta_rad, double rate_rad_s) {
  theta_ = theta_rad;
  theta_dot_ = rate_rad_s;
  theta_ddot_ = 0.0;
}

double Seesaw::smallOscillationPeriod_s() const {
  if (s_z_ >= 0.0) return std::numeric_limits<double>::infinity();
  return 2.0 * std::numbers::pi * std::sqrt(inertia_ / (-kGravity_m_per_s2 * s_z_));
}

void Seesaw::integrate(double h, const std::array<double, 3>& torque_nm, double) {
  // The pivot's bearing takes every torque but the one about its own axis (body x).
  const double gravity = -kGravity_m_per_s2 * (s_y_ * std::cos(theta_) - s_z_ * std::sin(theta_));
  theta_ddot_ = (torque_nm[0] + gravity - p_.pivot_damping_nms_per_rad * theta_dot_) / inertia_;
  theta_dot_ += h * theta_ddot_;  // semi-implicit Euler: keeps an undamped swing's energy
  theta_ += h * theta_dot_;
  const double stop = p_.stop_deg * kDegToRad;
  if (theta_ > stop && theta_dot_ > 0.0) {
    theta_ = stop;
    theta_dot_ = -p_.stop_restitution * theta_dot_;
  } else if (theta_ < -stop && theta_dot_ < 0.0) {
    theta_ = -stop;
    theta_dot_ = -p_.stop_restitution * theta_dot_;
  }
}

BodyState Seesaw::body() const {
  BodyState b;
  b.q_wxyz = {std::cos(theta_ / 2), std::sin(theta_ / 2), 0.0, 0.0};
  b.rate_rad_s = {theta_dot_, 0.0, 0.0};
  b.accel_rad_s2 = {theta_ddot_, 0.0, 0.0};
  return b;
}

}  // namespace plant

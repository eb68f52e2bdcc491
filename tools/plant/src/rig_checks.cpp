// The attitude rigs against hand calculations (plant/rig_checks.hpp).
#include "plant/rig_checks.hpp"

#include <cmath>
#include <numbers>

#include "plant/environment.hpp"
#include "plant/gimbal.hpp"
#include "plant/params.hpp"

namespace plant {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = 180.0 / kPi;
constexpr double kH = AttitudeRig::kMaxSubstep_s;

Seesaw seesawWith(double damping, const std::string& preset) {
  SeesawParams p = SeesawParams::benchRig();
  p.pivot_damping_nms_per_rad = damping;
  return Seesaw(p, {presetParams(preset), presetParams(preset)});
}

// Period from upward zero crossings and damping ratio from the peaks of a free swing.
void swing(Seesaw& s, double seconds, double& period_s, double& zeta) {
  std::vector<double> ups, peaks;
  double prev = s.angle_rad(), prev_rate = s.rate_rad_s();
  for (double t = 0; t < seconds; t += kH) {
    s.step(kH);
    const double a = s.angle_rad();
    if (prev < 0 && a >= 0) ups.push_back(s.time_s() - kH * a / (a - prev));
    if (prev_rate > 0 && s.rate_rad_s() <= 0) peaks.push_back(a);
    prev = a;
    prev_rate = s.rate_rad_s();
  }
  period_s = ups.size() > 1 ? (ups.back() - ups.front()) / static_cast<double>(ups.size() - 1) : 0;
  const double delta =
      peaks.size() > 1 ? std::log(peaks.front() / peaks.back()) / static_cast<double>(peaks.size() - 1) : 0;
  zeta = delta / std::sqrt(4 * kPi * kPi + delta * delta);
}

Gimbal quietGimbal(const std::string& preset) {
  GimbalParams p;
  p.layout = Layout::kX;
  p.damping_nms_per_rad = {0, 0, 0};
  const ActuatorParams m = presetParams(preset);
  return Gimbal(p, {m, m, m, m});
}

void torqueSteps(const std::string& preset, GimbalChecks& c) {
  for (int axis = 0; axis < 3; ++axis) {
    Gimbal g = quietGimbal(preset);
    std::array<double, 3> tau{};
    tau[axis] = 0.05;
    g.setDisturbanceTorque(tau);
    g.step(0.2);
    const RigTruth t = g.truth();
    const double alpha = 0.05 / c.inertia_kgm2[axis];
    const double angle = axis == 0 ? t.roll_deg : axis == 1 ? t.pitch_deg : t.yaw_deg;
    c.alpha_rad_s2[axis] = {alpha, t.accel_dps2[axis] / kDeg};
    c.rate_dps[axis] = {alpha * 0.2 * kDeg, t.rate_dps[axis]};
    c.angle_deg[axis] = {0.5 * alpha * 0.04 * kDeg, angle};
  }
}

void motorStep(const std::string& preset, GimbalChecks& c) {
  Gimbal g = quietGimbal(preset);
  for (int i = 0; i < 4; ++i) g.holdPulse(i, 1450);
  g.step(1.5);
  g.setState({1, 0, 0, 0}, {0, 0, 0});
  g.holdPulse(0, 1500);
  g.holdPulse(1, 1500);
  std::vector<double> tau;
  for (int i = 0; i < 2000; ++i) {
    g.step(kH);
    tau.push_back(g.truth().motor_torque_nm[0]);
  }
  for (std::size_t i = 0; i < tau.size(); ++i)
    if (tau[i] >= 0.632 * tau.back()) {
      c.motor_step_t63_s = static_cast<double>(i + 1) * kH;
      break;
    }
  const RigTruth t = g.truth();
  c.motor_step_roll_nm = tau.back();
  c.motor_step_roll_deg = t.roll_deg;
  c.motor_step_rate_dps = t.rate_dps[0];
}

void precession(const std::string& preset, GimbalChecks& c) {
  Gimbal g = quietGimbal(preset);
  const double omega = 10.0, wx = 0.1;
  g.setState({1, 0, 0, 0}, {wx, 0, omega});
  const double lambda = omega * (c.inertia_kgm2[2] - c.inertia_kgm2[0]) / c.inertia_kgm2[0];
  double t_half = 0, lowest = wx;  // the x rate's trough: half a precession period
  while (g.time_s() < 2 * kPi / lambda) {
    g.step(kH);
    const double now = g.truth().rate_dps[0] / kDeg;
    if (now < lowest) lowest = now, t_half = g.time_s();
  }
  c.precession_rad_s = lambda;
  c.precession_half_period_s = {kPi / lambda, t_half};
}

void yaw(const std::string& preset, GimbalChecks& c) {
  Gimbal g = quietGimbal(preset);
  for (int i = 0; i < 4; ++i) g.holdPulse(i, 1450);
  g.step(1.0);
  g.holdPulse(0, 1550);
  g.holdPulse(2, 1550);
  g.step(1.0);
  const RigTruth t = g.truth();
  c.yaw_drag_ccw_nm = g.actuator(0).torque_nm() + g.actuator(2).torque_nm();
  c.yaw_drag_cw_nm = g.actuator(1).torque_nm() + g.actuator(3).torque_nm();
  c.yaw_torque_nm = {c.yaw_drag_cw_nm - c.yaw_drag_ccw_nm, t.motor_torque_nm[2]};
  c.yaw_rate_after_1s_dps = t.rate_dps[2];
}

}  // namespace

double HandVsSimulated::errorPct() const {
  return hand == 0 ? 0 : 100.0 * std::fabs(simulated - hand) / std::fabs(hand);
}

SeesawChecks checkSeesaw(const std::string& preset) {
  SeesawChecks c;
  c.preset = preset;
  Seesaw s = seesawWith(0.0, preset);
  c.parts = s.parts();
  c.inertia_kgm2 = s.inertia_kgm2();
  c.mass_moment_z_kgm = s.massMomentZ_kgm();
  c.stiffness_nm_per_rad = -kGravity_m_per_s2 * s.massMomentZ_kgm();
  double period = 0, zeta = 0;
  s.setAngle(2.0 / kDeg);
  swing(s, 12.0, period, zeta);
  c.period_s = {s.smallOscillationPeriod_s(), period};
  const SeesawParams rig = SeesawParams::benchRig();
  c.damping_nms_per_rad = rig.pivot_damping_nms_per_rad;
  Seesaw d = seesawWith(c.damping_nms_per_rad, preset);
  d.setAngle(3.0 / kDeg);
  swing(d, 15.0, period, zeta);
  c.damping_ratio = {c.damping_nms_per_rad / (2 * std::sqrt(d.inertia_kgm2() * c.stiffness_nm_per_rad)), zeta};
  Seesaw e = seesawWith(0.0, preset);
  e.setAngle(24.0 / kDeg, 2.0);
  for (int i = 0; i < 40 && c.stop_rebound_rad_s == 0; ++i) {
    const double r = e.rate_rad_s();
    e.step(kH);
    if (r > 0 && e.rate_rad_s() < 0) c.stop_hit_rad_s = r, c.stop_rebound_rad_s = e.rate_rad_s();
  }
  c.stop_deg = rig.stop_deg;
  c.restitution = rig.stop_restitution;
  return c;
}

GimbalChecks checkGimbal(const std::string& preset) {
  GimbalChecks c;
  c.preset = preset;
  const GimbalParams p;
  c.inertia_kgm2 = p.inertia_kgm2;
  c.arm_m = p.arm_m;
  torqueSteps(preset, c);
  motorStep(preset, c);
  precession(preset, c);
  yaw(preset, c);
  return c;
}

}  // namespace plant

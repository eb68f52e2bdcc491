// `thrustcal plant rig seesaw|gimbal`: the attitude rigs' physics against hand calculations,
// the figures of docs/sim.md ("The virtual airframe"). Plant only, no firmware.
#include "plant/rig_cli.hpp"

#include <fmt/core.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "plant/gimbal.hpp"
#include "plant/params.hpp"
#include "plant/seesaw.hpp"

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
  const double delta = peaks.size() > 1 ? std::log(peaks.front() / peaks.back()) / static_cast<double>(peaks.size() - 1) : 0;
  zeta = delta / std::sqrt(4 * kPi * kPi + delta * delta);
}

void printSeesaw(const std::string& preset) {
  Seesaw s = seesawWith(0.0, preset);
  fmt::print("seesaw (SeesawParams::benchRig, motors {}): parts about the pivot (y along the beam, z up)\n", preset);
  fmt::print("  {:<28} {:>8} {:>8} {:>8} {:>14}\n", "part", "mass kg", "y m", "z m", "I kg m^2");
  for (const RigPart& p : s.parts())
    fmt::print("  {:<28} {:>8.3f} {:>8.3f} {:>8.3f} {:>14.6f}\n", p.name, p.mass_kg, p.y_m, p.z_m,
               p.mass_kg * (p.y_m * p.y_m + p.z_m * p.z_m) + p.own_inertia_kgm2);
  const double k = -kGravity_m_per_s2 * s.massMomentZ_kgm();
  fmt::print("  I = {:.6f} kg m^2, S_z = {:.6f} kg m (centre of gravity below the pivot), k = -g S_z = {:.4f} N m/rad\n",
             s.inertia_kgm2(), s.massMomentZ_kgm(), k);
  double period = 0, zeta = 0;
  s.setAngle(2.0 / kDeg);
  swing(s, 12.0, period, zeta);
  fmt::print("  small-oscillation period: hand 2 pi sqrt(I/k) = {:.4f} s, simulated (2 deg swing, no damping) {:.4f} s\n",
             s.smallOscillationPeriod_s(), period);
  const double c = SeesawParams::benchRig().pivot_damping_nms_per_rad;
  Seesaw d = seesawWith(c, preset);
  d.setAngle(3.0 / kDeg);
  swing(d, 15.0, period, zeta);
  fmt::print("  free decay with c = {} N m s/rad: damping ratio hand c / (2 sqrt(I k)) = {:.4f}, simulated (log decrement) {:.4f}\n",
             c, c / (2 * std::sqrt(d.inertia_kgm2() * k)), zeta);
  Seesaw e = seesawWith(0.0, preset);
  e.setAngle(24.0 / kDeg, 2.0);
  double before = 0, after = 0;
  for (int i = 0; i < 40 && after == 0; ++i) {
    const double r = e.rate_rad_s();
    e.step(kH);
    if (r > 0 && e.rate_rad_s() < 0) before = r, after = e.rate_rad_s();
  }
  fmt::print("  end stop at +-{:g} deg: hits at {:.3f} rad/s, bounces back at {:.3f} rad/s (restitution {:.2f})\n",
             SeesawParams::benchRig().stop_deg, before, after, -after / before);
}

Gimbal quietGimbal(const std::string& preset, Layout layout = Layout::kX) {
  GimbalParams p;
  p.layout = layout;
  p.damping_nms_per_rad = {0, 0, 0};
  const ActuatorParams m = presetParams(preset);
  return Gimbal(p, {m, m, m, m});
}

void printTorqueStep(const std::string& preset) {
  const GimbalParams defaults;
  fmt::print("  torque step 0.05 N m from rest, 0.2 s (no damping):\n");
  for (int axis = 0; axis < 3; ++axis) {
    Gimbal g = quietGimbal(preset);
    std::array<double, 3> tau{};
    tau[axis] = 0.05;
    g.setDisturbanceTorque(tau);
    g.step(0.2);
    const RigTruth t = g.truth();
    const double alpha = 0.05 / defaults.inertia_kgm2[axis];
    const double angle = axis == 0 ? t.roll_deg : axis == 1 ? t.pitch_deg : t.yaw_deg;
    fmt::print("    {}: alpha hand {:.4f} rad/s^2, simulated {:.4f}; rate at 0.2 s hand {:.3f} deg/s, simulated {:.3f};"
               " angle hand {:.4f} deg, simulated {:.4f}\n",
               "xyz"[axis], alpha, t.accel_dps2[axis] / kDeg, alpha * 0.2 * kDeg, t.rate_dps[axis],
               0.5 * alpha * 0.04 * kDeg, angle);
  }
}

void printMotorStep(const std::string& preset) {
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
  double t63 = 0;
  for (std::size_t i = 0; i < tau.size(); ++i)
    if (tau[i] >= 0.632 * tau.back()) {
      t63 = static_cast<double>(i + 1) * kH;
      break;
    }
  const RigTruth t = g.truth();
  fmt::print("  motor step (X, hover 1450 us, left pair 0+1 to 1500 us): roll torque {:.4f} N m after 0.5 s, "
             "63 % after {:.3f} s (the motors' time constant); roll {:.2f} deg, rate {:.1f} deg/s at 0.5 s\n",
             tau.back(), t63, t.roll_deg, t.rate_dps[0]);
}

void printPrecession(const std::string& preset) {
  Gimbal g = quietGimbal(preset);
  const double omega = 10.0, wx = 0.1;
  g.setState({1, 0, 0, 0}, {wx, 0, omega});
  const double lambda = omega * (0.032 - 0.018) / 0.018;
  double t_half = 0, lowest = wx;  // the x rate's trough: half a precession period
  while (g.time_s() < 2 * kPi / lambda) {
    g.step(kH);
    const double now = g.truth().rate_dps[0] / kDeg;
    if (now < lowest) lowest = now, t_half = g.time_s();
  }
  fmt::print("  torque-free spin 10 rad/s about z with 0.1 rad/s about x: precession hand Omega (Izz-Ixx)/Ixx = {:.4f} rad/s "
             "(half period {:.4f} s), simulated half period {:.4f} s\n",
             lambda, kPi / lambda, t_half);
}

void printYaw(const std::string& preset) {
  Gimbal g = quietGimbal(preset);
  for (int i = 0; i < 4; ++i) g.holdPulse(i, 1450);
  g.step(1.0);
  g.holdPulse(0, 1550);
  g.holdPulse(2, 1550);
  g.step(1.0);
  const RigTruth t = g.truth();
  const double q_ccw = g.actuator(0).torque_nm() + g.actuator(2).torque_nm();
  const double q_cw = g.actuator(1).torque_nm() + g.actuator(3).torque_nm();
  fmt::print("  yaw: CCW pair (0, 2) at 1550 us, CW pair at 1450 us: drag torques {:.4f} / {:.4f} N m, yaw torque "
             "{:.4f} N m (hand {:.4f}), yaw rate after 1 s {:.1f} deg/s\n",
             q_ccw, q_cw, t.motor_torque_nm[2], q_cw - q_ccw, t.rate_dps[2]);
}

void printGimbal(const std::string& preset) {
  const GimbalParams p;
  fmt::print("gimbal (GimbalParams defaults, motors {}): I = {}/{}/{} kg m^2, arm {} m, layouts plus and X\n",
             preset, p.inertia_kgm2[0], p.inertia_kgm2[1], p.inertia_kgm2[2], p.arm_m);
  printTorqueStep(preset);
  printMotorStep(preset);
  printPrecession(preset);
  printYaw(preset);
}

}  // namespace

void addRigCommands(CLI::App* plant) {
  CLI::App* rig = plant->add_subcommand(
      "rig", "The attitude rigs (seesaw, gimbal) against hand calculations: parts, inertia, period,\n"
             "damping, end stops; torque steps, a motor step, precession, yaw from drag");
  auto which = std::make_shared<std::string>("seesaw");
  auto preset = std::make_shared<std::string>("kv1100_9x4.7");
  rig->add_option("which", *which, "seesaw or gimbal")
      ->check(CLI::IsMember({"seesaw", "gimbal"}))
      ->capture_default_str();
  rig->add_option("--preset", *preset, "the motors (see thrustcal plant presets)")->capture_default_str();
  rig->callback([which, preset] {
    if (*which == "seesaw")
      printSeesaw(*preset);
    else
      printGimbal(*preset);
  });
}

}  // namespace plant

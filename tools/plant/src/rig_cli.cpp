// `thrustcal plant rig seesaw|gimbal`: the attitude rigs' physics against hand calculations
// (plant/rig_checks.hpp), the figures of docs/sim.md ("The rigs"). Plant only, no firmware.
#include "plant/rig_cli.hpp"

#include <fmt/core.h>

#include "plant/rig_checks.hpp"

namespace plant {
namespace {

void printSeesaw(const std::string& preset) {
  const SeesawChecks c = checkSeesaw(preset);
  fmt::print("seesaw (SeesawParams::benchRig, motors {}): parts about the pivot (y along the beam, z up)\n", preset);
  fmt::print("  {:<28} {:>8} {:>8} {:>8} {:>14}\n", "part", "mass kg", "y m", "z m", "I kg m^2");
  for (const RigPart& p : c.parts)
    fmt::print("  {:<28} {:>8.3f} {:>8.3f} {:>8.3f} {:>14.6f}\n", p.name, p.mass_kg, p.y_m, p.z_m,
               p.mass_kg * (p.y_m * p.y_m + p.z_m * p.z_m) + p.own_inertia_kgm2);
  fmt::print("  I = {:.6f} kg m^2, S_z = {:.6f} kg m (centre of gravity below the pivot), k = -g S_z = {:.4f} N m/rad\n",
             c.inertia_kgm2, c.mass_moment_z_kgm, c.stiffness_nm_per_rad);
  fmt::print("  small-oscillation period: hand 2 pi sqrt(I/k) = {:.4f} s, simulated (2 deg swing, no damping) {:.4f} s\n",
             c.period_s.hand, c.period_s.simulated);
  fmt::print("  free decay with c = {} N m s/rad: damping ratio hand c / (2 sqrt(I k)) = {:.4f}, simulated (log decrement) {:.4f}\n",
             c.damping_nms_per_rad, c.damping_ratio.hand, c.damping_ratio.simulated);
  fmt::print("  end stop at +-{:g} deg: hits at {:.3f} rad/s, bounces back at {:.3f} rad/s (restitution {:.2f})\n",
             c.stop_deg, c.stop_hit_rad_s, c.stop_rebound_rad_s, -c.stop_rebound_rad_s / c.stop_hit_rad_s);
}

void printGimbal(const std::string& preset) {
  const GimbalChecks c = checkGimbal(preset);
  fmt::print("gimbal (GimbalParams defaults, motors {}): I = {}/{}/{} kg m^2, arm {} m, layouts plus and X\n",
             preset, c.inertia_kgm2[0], c.inertia_kgm2[1], c.inertia_kgm2[2], c.arm_m);
  fmt::print("  torque step 0.05 N m from rest, 0.2 s (no damping):\n");
  for (int axis = 0; axis < 3; ++axis)
    fmt::print("    {}: alpha hand {:.4f} rad/s^2, simulated {:.4f}; rate at 0.2 s hand {:.3f} deg/s, simulated {:.3f};"
               " angle hand {:.4f} deg, simulated {:.4f}\n",
               "xyz"[axis], c.alpha_rad_s2[axis].hand, c.alpha_rad_s2[axis].simulated, c.rate_dps[axis].hand,
               c.rate_dps[axis].simulated, c.angle_deg[axis].hand, c.angle_deg[axis].simulated);
  fmt::print("  motor step (X, hover 1450 us, left pair 0+1 to 1500 us): roll torque {:.4f} N m after 0.5 s, "
             "63 % after {:.3f} s (the motors' time constant); roll {:.2f} deg, rate {:.1f} deg/s at 0.5 s\n",
             c.motor_step_roll_nm, c.motor_step_t63_s, c.motor_step_roll_deg, c.motor_step_rate_dps);
  fmt::print("  torque-free spin 10 rad/s about z with 0.1 rad/s about x: precession hand Omega (Izz-Ixx)/Ixx = {:.4f} rad/s "
             "(half period {:.4f} s), simulated half period {:.4f} s\n",
             c.precession_rad_s, c.precession_half_period_s.hand, c.precession_half_period_s.simulated);
  fmt::print("  yaw: CCW pair (0, 2) at 1550 us, CW pair at 1450 us: drag torques {:.4f} / {:.4f} N m, yaw torque "
             "{:.4f} N m (hand {:.4f}), yaw rate after 1 s {:.1f} deg/s\n",
             c.yaw_drag_ccw_nm, c.yaw_drag_cw_nm, c.yaw_torque_nm.simulated, c.yaw_torque_nm.hand,
             c.yaw_rate_after_1s_dps);
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

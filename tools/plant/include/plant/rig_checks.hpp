// The attitude rigs' physics against hand calculations (docs/sim.md, "The rigs"): what
// `thrustcal plant rig seesaw|gimbal` prints and `thrustcal bench rigs` puts in the results.
// Plant only, no firmware; each check a few simulated seconds of one rig.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "plant/seesaw.hpp"

namespace plant {

// A simulated figure beside the one worked out by hand.
struct HandVsSimulated {
  double hand = 0, simulated = 0;
  double errorPct() const;  // |simulated - hand| / |hand|, in %
};

struct SeesawChecks {
  std::string preset;
  std::vector<RigPart> parts;
  double inertia_kgm2 = 0, mass_moment_z_kgm = 0, stiffness_nm_per_rad = 0;  // k = -g S_z
  HandVsSimulated period_s;        // small oscillation, 2 deg swing, no damping
  double damping_nms_per_rad = 0;  // the rig's default pivot damping
  HandVsSimulated damping_ratio;   // c / (2 sqrt(I k)) vs the log decrement of a free decay
  double stop_deg = 0;
  double stop_hit_rad_s = 0, stop_rebound_rad_s = 0;  // at the end stop
  double restitution = 0;                             // the rig's; simulated: -rebound / hit
};

struct GimbalChecks {
  std::string preset;
  std::array<double, 3> inertia_kgm2{};
  double arm_m = 0;
  // 0.05 N m from rest for 0.2 s about x, y, z (no damping)
  std::array<HandVsSimulated, 3> alpha_rad_s2{}, rate_dps{}, angle_deg{};
  // X layout hovering at 1450 us, the left pair (0, 1) stepped to 1500 us
  double motor_step_roll_nm = 0, motor_step_t63_s = 0, motor_step_roll_deg = 0, motor_step_rate_dps = 0;
  // torque-free spin 10 rad/s about z with 0.1 rad/s about x: half a precession period
  double precession_rad_s = 0;
  HandVsSimulated precession_half_period_s;
  // yaw: CCW pair (0, 2) at 1550 us, CW pair at 1450 us
  double yaw_drag_ccw_nm = 0, yaw_drag_cw_nm = 0;
  HandVsSimulated yaw_torque_nm;  // hand: Q_cw - Q_ccw from the motors' own drag torques
  double yaw_rate_after_1s_dps = 0;
};

SeesawChecks checkSeesaw(const std::string& preset);
GimbalChecks checkGimbal(const std::string& preset);

}  // namespace plant

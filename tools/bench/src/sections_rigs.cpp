// Benchmark 10: the attitude rigs' physics against hand calculations (plant/rig_checks.hpp, the
// same checks as `thrustcal plant rig seesaw|gimbal`): docs/sim.md's rig tables are generated
// from this section's JSON. Plant only: a few simulated seconds of each rig, no firmware.
#include <algorithm>

#include <fmt/format.h>

#include "bench/sections.hpp"
#include "plant/rig_checks.hpp"

namespace bench {
namespace {

constexpr double kRigWithinPct = 0.1;  // every simulated figure this close to its hand value
constexpr const char* kRigMotorsPreset = "kv1100_9x4.7";

nlohmann::json pair(const plant::HandVsSimulated& v) {
  return {{"hand", v.hand}, {"simulated", v.simulated}, {"error_pct", v.errorPct()}};
}

struct Rows {
  Table table{"10. The attitude rigs against hand calculations (plant only)",
              {"rig", "figure", "hand", "simulated", "error", "target", "met?"}};
  double worst_pct = 0;
  std::string worst;
  void add(const std::string& rig, const std::string& what, const plant::HandVsSimulated& v, int decimals) {
    const bool met = v.errorPct() <= kRigWithinPct;
    table.addRow({rig, what, fixed(v.hand, decimals), fixed(v.simulated, decimals),
                  fmt::format("{:.3f} %", v.errorPct()), fmt::format("<= {} %", kRigWithinPct), verdict(met)});
    if (v.errorPct() >= worst_pct) worst_pct = v.errorPct(), worst = rig + ": " + what;
  }
};

}  // namespace

Section rigsSection() {
  Section s;
  s.key = "rigs";
  const plant::SeesawChecks see = plant::checkSeesaw(kRigMotorsPreset);
  const plant::GimbalChecks gim = plant::checkGimbal(kRigMotorsPreset);
  Rows r;
  r.add("seesaw", "small-oscillation period, s (2 deg swing, no damping)", see.period_s, 4);
  r.add("seesaw", "damping ratio (log decrement of a free decay)", see.damping_ratio, 4);
  const plant::HandVsSimulated rebound{see.restitution, -see.stop_rebound_rad_s / see.stop_hit_rad_s};
  r.add("seesaw", fmt::format("end-stop restitution (hits at {:.3f} rad/s)", see.stop_hit_rad_s), rebound, 3);
  for (int axis = 0; axis < 3; ++axis) {
    const std::string about = fmt::format("0.05 N m step about {}: ", "xyz"[axis]);
    r.add("gimbal", about + "alpha, rad/s^2", gim.alpha_rad_s2[axis], 4);
    r.add("gimbal", about + "rate at 0.2 s, deg/s", gim.rate_dps[axis], 3);
    r.add("gimbal", about + "angle at 0.2 s, deg", gim.angle_deg[axis], 4);
  }
  r.add("gimbal", "precession half period, s (spin 10 rad/s about z)", gim.precession_half_period_s, 4);
  r.add("gimbal", "yaw torque, N m (CCW pair 1550 us, CW pair 1450 us)", gim.yaw_torque_nm, 4);
  r.table.addNote(fmt::format("motors {}; the rigs' own figures without a hand value: gimbal motor step (X, hover "
                              "1450 us, left pair to 1500 us) roll torque {:.3f} N m, 63 % after {:.3f} s; yaw rate "
                              "{:.0f} deg/s after 1 s",
                              kRigMotorsPreset, gim.motor_step_roll_nm, gim.motor_step_t63_s, gim.yaw_rate_after_1s_dps));
  r.table.addNote("the same checks print with `thrustcal plant rig seesaw|gimbal`; docs/sim.md, \"The rigs\"");
  s.tables.push_back(r.table);

  nlohmann::json torque = nlohmann::json::array();
  for (int axis = 0; axis < 3; ++axis)
    torque.push_back({{"axis", std::string(1, "xyz"[axis])},
                      {"alpha_rad_s2", pair(gim.alpha_rad_s2[axis])},
                      {"rate_dps", pair(gim.rate_dps[axis])},
                      {"angle_deg", pair(gim.angle_deg[axis])}});
  s.json = {
      {"preset", kRigMotorsPreset},
      {"seesaw",
       {{"inertia_kgm2", see.inertia_kgm2},
        {"mass_moment_z_kgm", see.mass_moment_z_kgm},
        {"period_s", pair(see.period_s)},
        {"damping_nms_per_rad", see.damping_nms_per_rad},
        {"damping_ratio", pair(see.damping_ratio)},
        {"stop", {{"deg", see.stop_deg}, {"hit_rad_s", see.stop_hit_rad_s}, {"rebound_rad_s", -see.stop_rebound_rad_s},
                  {"restitution", pair(rebound)}}}}},
      {"gimbal",
       {{"inertia_kgm2", gim.inertia_kgm2},
        {"torque_step", torque},
        {"motor_step", {{"roll_nm", gim.motor_step_roll_nm}, {"t63_s", gim.motor_step_t63_s},
                        {"roll_deg", gim.motor_step_roll_deg}, {"rate_dps", gim.motor_step_rate_dps}}},
        {"precession", {{"rad_s", gim.precession_rad_s}, {"half_period_s", pair(gim.precession_half_period_s)}}},
        {"yaw", {{"drag_ccw_nm", gim.yaw_drag_ccw_nm}, {"drag_cw_nm", gim.yaw_drag_cw_nm},
                 {"torque_nm", pair(gim.yaw_torque_nm)}, {"rate_after_1s_dps", gim.yaw_rate_after_1s_dps}}}}},
      {"worst_error_pct", r.worst_pct}};
  s.targets.push_back(TargetCheck{"the rigs against hand calculations (period, damping, end stop, torque steps, "
                                  "precession, yaw)",
                                  fmt::format("worst {:.3f} % ({})", r.worst_pct, r.worst),
                                  fmt::format("every figure within {} %", kRigWithinPct), r.worst_pct <= kRigWithinPct});
  return s;
}

}  // namespace bench

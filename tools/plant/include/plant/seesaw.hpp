// The 1-DOF seesaw test rig: a beam on a pivot (its axis along body x) with motor 0 at
// y = +arm (left) and motor 1 at y = -arm (right), both pushing along body z.
//   I theta'' = arm (F0 - F1) - g (S_y cos theta - S_z sin theta) - c theta'
// where I = sum(m (y^2 + z^2) + I_own) and S_y = sum(m y), S_z = sum(m z) over the named parts
// (positions from the pivot in the beam's axes): a centre of gravity below the pivot (S_z < 0)
// makes it a pendulum of period 2 pi sqrt(I / (-g S_z)) for small angles, one above it is
// unstable. c: viscous pivot damping. End stops at +-stop: the beam bounces back with
// restitution e times its speed (0: it stops dead, 1: elastic).
// The motors' and propellers' masses come from their ActuatorParams; the default parts (what
// they are and why): docs/sim.md, "The virtual airframe".
#pragma once
#include <string>
#include <vector>

#include "plant/attitude_rig.hpp"

namespace plant {

struct RigPart {
  std::string name;
  double mass_kg = 0.0;
  double y_m = 0.0, z_m = 0.0;     // from the pivot, beam axes (y along the beam, z up)
  double own_inertia_kgm2 = 0.0;   // about its own centre, around the pivot axis
};

struct SeesawParams {
  double arm_m = 0.225;               // pivot to each motor's axis
  double motor_height_m = 0.02;       // the motor's centre above the pivot axis
  double prop_height_m = 0.05;        // the propeller's plane above the pivot axis
  std::vector<RigPart> parts;         // everything but the motors and propellers
  double pivot_damping_nms_per_rad = 0.004;
  double stop_deg = 25.0;
  double stop_restitution = 0.3;
  RigCommon common;

  // A 0.5 m, 120 g aluminium beam, the flight board with its IMU 3 cm above the pivot and a
  // 200 g ballast 10 cm below it (a pendulum: it rests level with the motors off).
  static SeesawParams benchRig();
};

class Seesaw : public AttitudeRig {
 public:
  // motors: [0] at +arm (left), [1] at -arm (right).
  Seesaw(const SeesawParams& params, const std::array<ActuatorParams, 2>& motors);

  double angle_rad() const { return theta_; }
  double rate_rad_s() const { return theta_dot_; }
  void setAngle(double theta_rad, double rate_rad_s = 0.0);

  // The beam with its motors and propellers, about the pivot.
  double inertia_kgm2() const { return inertia_; }
  double massMomentY_kgm() const { return s_y_; }  // S_y
  double massMomentZ_kgm() const { return s_z_; }  // S_z (< 0: centre of gravity below the pivot)
  // Small-oscillation period with the motors off and no damping (infinite if not pendulous).
  double smallOscillationPeriod_s() const;
  // The parts with the motors and propellers added, as the rig sums them.
  const std::vector<RigPart>& parts() const { return all_parts_; }
  const SeesawParams& params() const { return p_; }

 protected:
  void integrate(double h, const std::array<double, 3>& torque_nm, double rotor_momentum_nms) override;
  BodyState body() const override;

 private:
  SeesawParams p_;
  std::vector<RigPart> all_parts_;
  double inertia_ = 0.0, s_y_ = 0.0, s_z_ = 0.0;
  double theta_ = 0.0, theta_dot_ = 0.0, theta_ddot_ = 0.0;
};

}  // namespace plant

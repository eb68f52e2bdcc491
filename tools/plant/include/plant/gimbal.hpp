// The quadrocopter on a 3-DOF gimbal: attitude only, the pivot at (or, with cg_below_pivot_m,
// just above) the centre of gravity. Euler's equations for the rigid airframe,
//   I w' = tau_motors - w x (I w + h_rotors) - D w + tau_gravity,   I = diag(Ixx, Iyy, Izz)
// with the motors' torque and the rotors' momentum from plant::AttitudeRig, integrated with
// RK4 per 0.25 ms sub-step; the attitude is a unit quaternion (no gimbal lock, full
// rotation), q' = q (0, w) / 2 integrated exactly for the sub-step's mean rate.
// Layouts, body axes x forward, y left (motor i, spin +1 = counter-clockwise from above):
//   X:    0 front-left (+c,+c) CCW, 1 rear-left (-c,+c) CW, 2 rear-right (-c,-c) CCW,
//         3 front-right (+c,-c) CW, c = arm / sqrt 2 (as plant::QuadFrame)
//   plus: 0 front (+arm,0) CCW, 1 left (0,+arm) CW, 2 rear (-arm,0) CCW, 3 right (0,-arm) CW
#pragma once
#include <array>

#include "plant/attitude_rig.hpp"

namespace plant {

enum class Layout { kPlus, kX };
const char* layoutName(Layout layout);
// The four motors' positions and spins in a layout (see above).
std::array<MotorMount, 4> quadMounts(Layout layout, double arm_m);

struct GimbalParams {
  Layout layout = Layout::kX;
  double arm_m = 0.225;                                    // centre to motor axis
  std::array<double, 3> inertia_kgm2{0.018, 0.018, 0.032};  // the Iqarus-class airframe, 1.2 kg
  std::array<double, 3> damping_nms_per_rad{0.002, 0.002, 0.002};  // gimbal bearings and air
  double mass_kg = 1.2;
  double cg_below_pivot_m = 0.0;  // > 0: pendulous (restoring), < 0: top-heavy
  RigCommon common;
};

class Gimbal : public AttitudeRig {
 public:
  Gimbal(const GimbalParams& params, const std::array<ActuatorParams, 4>& motors);

  // Sets the attitude (body to world, normalised here) and the body rates.
  void setState(const std::array<double, 4>& q_wxyz, const std::array<double, 3>& rate_rad_s);
  const GimbalParams& params() const { return p_; }

 protected:
  void integrate(double h, const std::array<double, 3>& torque_nm, double rotor_momentum_nms) override;
  BodyState body() const override;

 private:
  GimbalParams p_;
  std::array<double, 4> q_{1, 0, 0, 0};
  std::array<double, 3> w_{}, w_dot_{};
};

}  // namespace plant

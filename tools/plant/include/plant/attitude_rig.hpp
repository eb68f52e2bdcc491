// What the attitude rigs share (the seesaw, plant/seesaw.hpp; the quad on a gimbal,
// plant/gimbal.hpp): motors that keep their dynamics (plant::Actuator: ESC, motor time
// constant, spin-down on drag), one power source with its sag, and a rigid body turning about
// a fixed pivot, advanced in sub-steps of at most 0.25 ms.
//
// Axes: body x forward, y left, z up (FLU, as plant::QuadFrame); the world frame is the body's
// at rest. Angles and rates are right-handed about those axes: roll positive = right side
// down, pitch positive = nose down, yaw positive = nose left (counter-clockwise from above).
// Motor i sits at (x_i, y_i) in the body and pushes along body z; spin +1 = counter-clockwise
// seen from above. On the body it makes the torque
//   ( y_i F_i,  -x_i F_i,  -spin_i (Q_i + J_i dW_i/dt) )
// (thrust on its arm; the reaction to the motor's torque, which is the propeller's drag Q
// plus what spins the rotor up), and the rotors' angular momentum sum(spin_i J_i W_i) z
// turns with the body (gyroscopic torque -w x h).
// The truth (attitude, body rates, the specific force at the IMU's mount) is what an IMU
// measures and what a log records. Faults: a dead motor or ESC, a propeller losing thrust.
#pragma once
#include <array>
#include <vector>

#include "plant/actuator.hpp"
#include "plant/power_source.hpp"

namespace plant {

struct RigTruth {
  double t_s = 0.0;
  std::array<double, 4> q_wxyz{1, 0, 0, 0};  // body to world
  double roll_deg = 0.0, pitch_deg = 0.0, yaw_deg = 0.0;  // Z-Y-X Euler angles of q
  std::array<double, 3> rate_dps{};           // body rates about x, y, z
  std::array<double, 3> accel_dps2{};         // body angular acceleration
  std::array<double, 3> specific_force_g{0, 0, 1};  // at the IMU's mount, body axes
  std::array<double, 3> motor_torque_nm{};    // the motors' torque on the body, body axes
};

struct MotorMount {
  double x_m = 0.0, y_m = 0.0;
  int spin = 1;  // +1 counter-clockwise seen from above, -1 clockwise
};

// What every rig has besides its body.
struct RigCommon {
  BatteryParams power;                 // default: a full 3S LiPo
  Environment env;
  std::array<double, 3> imu_mount_m{}; // the IMU's position from the pivot, body axes
  // Rotor imbalance: each motor shakes the IMU with a rotating acceleration in the body's x-y
  // plane at its rotor frequency, this amplitude at 10,000 rpm, scaling with rpm^2 (0: none).
  double vibration_g_at_10krpm = 0.0;
  // Each motor's propeller direction, +1 counter-clockwise seen from above, -1 clockwise, in
  // place of the rig's layout (firmware differ: MultiWii's QUADX turns its front-left propeller
  // clockwise, the gimbal's X layout counter-clockwise). Empty: the layout's.
  std::vector<int> spin;
  // The rotors' reaction on the body: each propeller's drag torque and its spin-up torque about
  // the motor's axis (the body's z). false is a diagnostic only (`sim swap
  // --no-reaction-torque`): the motors then push the body with their thrust alone, as if each
  // motor's torque-to-thrust ratio and inertia were nil, which no real rig is.
  bool reaction_torque = true;
};

// A rotation state the rigs report: body to world, body rates and angular acceleration.
struct BodyState {
  std::array<double, 4> q_wxyz{1, 0, 0, 0};
  std::array<double, 3> rate_rad_s{};
  std::array<double, 3> accel_rad_s2{};
};

class AttitudeRig {
 public:
  static constexpr double kMaxSubstep_s = 0.25e-3;

  AttitudeRig(const RigCommon& common, const std::vector<ActuatorParams>& motors,
              const std::vector<MotorMount>& mounts);
  virtual ~AttitudeRig() = default;

  int motors() const { return static_cast<int>(act_.size()); }
  // One ESC pulse (as plant::Actuator::setPulse); ignored by a dead motor.
  void setPulse(int motor, double pulse_us, double t_s);
  void holdPulse(int motor, double pulse_us);  // tests: armed, this pulse forever
  // Advances dt_s in sub-steps of at most kMaxSubstep_s.
  void step(double dt_s);
  double time_s() const { return t_s_; }
  RigTruth truth() const;

  // A torque on the body from outside (a push, a gust, a test's torque step), body axes,
  // held until changed.
  void setDisturbanceTorque(const std::array<double, 3>& torque_nm) { disturbance_nm_ = torque_nm; }

  // --- faults ---
  // The motor or its ESC dies: no drive from now on, the rotor coasts down on its drag.
  void killMotor(int motor);
  bool motorDead(int motor) const { return dead_.at(motor); }
  // Its propeller loses `share` (0..1) of its thrust (plant::Actuator::damagePropeller).
  void loseThrust(int motor, double share);

  Actuator& actuator(int motor) { return act_.at(motor); }
  const Actuator& actuator(int motor) const { return act_.at(motor); }
  const MotorMount& mount(int motor) const { return mounts_.at(motor); }
  PowerSource& power() { return power_; }
  double busVoltage_v() const { return bus_v_; }
  double busCurrent_a() const { return bus_current_a_; }
  const RigCommon& common() const { return common_; }

 protected:
  // Advances the body by h under the motors' torque (body axes) and the rotors' angular
  // momentum about body z.
  virtual void integrate(double h, const std::array<double, 3>& motor_torque_nm,
                         double rotor_momentum_nms) = 0;
  virtual BodyState body() const = 0;

 private:
  void substep(double h);

  RigCommon common_;
  std::vector<Actuator> act_;
  std::vector<MotorMount> mounts_;
  std::vector<bool> dead_;
  std::vector<double> rotor_angle_rad_;
  PowerSource power_;
  double t_s_ = 0.0;
  double bus_v_ = 0.0, bus_current_a_ = 0.0;
  std::array<double, 3> torque_nm_{};
  std::array<double, 3> disturbance_nm_{};
};

// Z-Y-X Euler angles (roll, pitch, yaw) in degrees of a unit quaternion (w, x, y, z).
std::array<double, 3> eulerDeg(const std::array<double, 4>& q_wxyz);

}  // namespace plant

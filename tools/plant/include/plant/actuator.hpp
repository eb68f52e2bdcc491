// One actuator: ESC + BLDC motor + propeller, stepped in (simulated) time.
//
// Electrical (no inductance: the electrical time constant is ~0.1 ms, far below the step):
//   u = d * V_bus, I = max(0, (u - Ke(T) w) / R(T)), R = R_winding(T) + R_esc, bus current d * I + idle.
// Mechanical: J dw/dt = Kt (I - I0) - Q_prop(w), J = rotor + propeller inertia,
//   integrated linearly-implicitly (stable for any dt up to ~10 ms).
// Speed time constant (small step around hover, 300 g, 11 V, kv1100_9x4.7):
//   tau = J / (Kt Ke / R + dQ/dw), which the fidelity test holds to the spec's 0.05..0.12 s
//   (`thrustcal plant step` measures it).
//   Spin-down is slower (no active braking: only propeller drag).
// Thermal: winding temperature first-order, see MotorParams.
//
// Cost: step() is a few dozen flops, no allocation, no transcendental functions.
#pragma once
#include "plant/environment.hpp"
#include "plant/params.hpp"

namespace plant {

// Current drawn from the bus as an affine function of the bus voltage, valid for one step:
// current_a(V) = conductance_s * V + offset_a. Loads are summed; a PowerSource solves for V.
struct BusLoad {
  double conductance_s = 0.0;
  double offset_a = 0.0;
  double currentAt_a(double bus_v) const { return conductance_s * bus_v + offset_a; }
  BusLoad& operator+=(const BusLoad& o) {
    conductance_s += o.conductance_s;
    offset_a += o.offset_a;
    return *this;
  }
};

struct OperatingPoint {
  double pulse_us = 0.0;
  double duty = 0.0;
  double bus_v = 0.0;       // at the ESC input
  double thrust_g = 0.0;
  double rpm = 0.0;
  double motor_current_a = 0.0;
  double bus_current_a = 0.0;  // what the battery/supply delivers to this ESC
  double torque_nm = 0.0;      // propeller drag torque (reaction on the frame)
};

class Actuator {
 public:
  explicit Actuator(const ActuatorParams& params = ActuatorParams(),
                    const Environment& env = Environment());

  // --- ESC input -------------------------------------------------------------------------
  // One servo pulse of width pulse_us that ended at t_s (same clock as step(): starts at 0 and
  // advances by dt_s per step; a pulse between two steps may carry its exact edge time).
  void setPulse(double pulse_us, double t_s);
  // Shortcut for the model lab and unit tests: arm now and hold this pulse forever (no
  // timeout). setPulse() afterwards returns to normal servo behaviour.
  void holdPulse(double pulse_us);
  bool isArmed() const { return armed_; }
  double lastPulse_us() const { return last_pulse_us_; }
  double duty() const;  // 0 when disarmed
  uint32_t acceptedPulses() const { return accepted_pulses_; }
  uint32_t rejectedPulses() const { return rejected_pulses_; }

  // --- time stepping -----------------------------------------------------------------------
  // How the bus current depends on the bus voltage during the next step (for PowerSource).
  BusLoad busLoad() const;
  // Advance by dt_s with bus_v at the ESC input. Returns the bus current, amps.
  double step(double dt_s, double bus_v);
  double time_s() const { return time_s_; }

  // --- state -------------------------------------------------------------------------------
  double thrust_g() const;
  double thrust_n() const;
  double torque_nm() const;          // propeller drag torque at the current speed
  double rpm() const;
  double omega_rad_per_s() const { return omega_; }
  double motorCurrent_a() const { return motor_current_a_; }
  double busCurrent_a() const { return bus_current_a_; }
  double windingTemp_c() const { return winding_temp_c_; }
  void setWindingTemp_c(double temp_c) { winding_temp_c_ = temp_c; }
  void setSpeed_rpm(double rpm);

  // --- steady state (no time stepping; uses the present winding temperature) ----------------
  OperatingPoint steadyState(double pulse_us, double bus_v) const;
  OperatingPoint steadyStateAtDuty(double duty, double bus_v) const;
  // Thrust of the steady state, and its inverse: the pulse that gives thrust_g at bus_v
  // (bisection; returns esc.full_us if thrust_g is out of reach, esc.start_us if <= 0).
  double pulseForThrust_us(double thrust_g, double bus_v) const;

  // --- damage (fault injection) --------------------------------------------------------------
  // The propeller loses `share` (0..1) of its thrust from now on, e.g. a blade tip gone: C_T and
  // C_P both scale by (1 - share), so the motor also spins up against less drag.
  void damagePropeller(double share);

  // --- parameters --------------------------------------------------------------------------
  const ActuatorParams& params() const { return p_; }
  const Environment& environment() const { return env_; }
  void setEnvironment(const Environment& env);

  // Static propeller laws at this actuator's air density (no state).
  double thrustAt_n(double omega_rad_per_s) const;
  double torqueAt_nm(double omega_rad_per_s) const;
  double ke_v_s_per_rad() const;  // at the present winding temperature (= Kt, N m / A)
  double resistance_ohm() const;  // winding (at temperature) + ESC

 private:
  double dutyForPulse(double pulse_us) const;
  double ctAt(double rpm) const;
  double cpAt(double rpm) const;
  double omegaSteady(double u_v, double ke, double r) const;

  ActuatorParams p_;
  Environment env_;
  double rho_ = 1.2;
  double inertia_ = 0.0;
  double ke25_ = 0.0;
  // ESC state
  bool armed_ = false;
  bool hold_ = false;
  double last_pulse_us_ = 0.0;
  double last_pulse_t_s_ = -1.0;
  double arm_since_s_ = -1.0;
  uint32_t accepted_pulses_ = 0;
  uint32_t rejected_pulses_ = 0;
  // physical state
  double time_s_ = 0.0;
  double omega_ = 0.0;
  double motor_current_a_ = 0.0;
  double bus_current_a_ = 0.0;
  double winding_temp_c_ = 20.0;
  double last_bus_v_ = 0.0;  // picks the conduction branch in busLoad()
  double d4_ = 0.0, d5_ = 0.0;  // D^4, D^5
};

}  // namespace plant

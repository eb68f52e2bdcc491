#include "plant/actuator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace plant {

namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kRadPerSToRpm = 60.0 / kTwoPi;
constexpr double kNewtonToGram = 1000.0 / kGravity_m_per_s2;
// Below this speed the no-load friction torque fades in linearly, so a stopped motor with no
// drive stays stopped instead of chattering around zero.
constexpr double kFrictionFadeRadPerS = 5.0;

double lerpClamped(double x, double x0, double x1, double y0, double y1) {
  if (x1 <= x0) return y0;
  const double f = std::clamp((x - x0) / (x1 - x0), 0.0, 1.0);
  return y0 + f * (y1 - y0);
}
}  // namespace

Actuator::Actuator(const ActuatorParams& params, const Environment& env) : p_(params) {
  inertia_ = p_.inertia_kgm2();
  ke25_ = 60.0 / (kTwoPi * p_.motor.kv_rpm_per_v);
  const double d = p_.prop.diameter_m;
  d4_ = d * d * d * d;
  d5_ = d4_ * d;
  setEnvironment(env);
  winding_temp_c_ = env.temp_c;
}

void Actuator::setEnvironment(const Environment& env) {
  env_ = env;
  rho_ = env.airDensity_kg_per_m3();
}

// ---------------------------------------------------------------------------------- ESC input

double Actuator::dutyForPulse(double pulse_us) const {
  const double span = p_.esc.full_us - p_.esc.start_us;
  if (span <= 0.0) return 0.0;
  return std::clamp((pulse_us - p_.esc.start_us) / span, 0.0, 1.0);
}

double Actuator::duty() const { return armed_ ? dutyForPulse(last_pulse_us_) : 0.0; }

void Actuator::setPulse(double pulse_us, double t_s) {
  const EscParams& e = p_.esc;
  const bool width_ok = pulse_us >= e.min_pulse_us && pulse_us <= e.max_pulse_us;
  const bool rate_ok = last_pulse_t_s_ < 0.0 || hold_ ||
                       (t_s - last_pulse_t_s_) >= 1.0 / e.max_frame_hz - 1e-9;
  if (!width_ok || !rate_ok) {
    ++rejected_pulses_;
    return;
  }
  ++accepted_pulses_;
  hold_ = false;
  last_pulse_us_ = pulse_us;
  last_pulse_t_s_ = t_s;
  if (armed_) return;
  if (pulse_us <= e.arm_max_us) {
    if (arm_since_s_ < 0.0) arm_since_s_ = t_s;
    if (t_s - arm_since_s_ >= e.arm_time_s) armed_ = true;
  } else {
    arm_since_s_ = -1.0;  // throttle not at minimum: the arming wait starts again
  }
}

void Actuator::holdPulse(double pulse_us) {
  hold_ = true;
  armed_ = true;
  last_pulse_us_ = pulse_us;
  last_pulse_t_s_ = time_s_;
}

void Actuator::damagePropeller(double share) {
  const double keep = std::clamp(1.0 - share, 0.0, 1.0);
  p_.prop.ct_low *= keep;
  p_.prop.ct_high *= keep;
  p_.prop.cp_low *= keep;
  p_.prop.cp_high *= keep;
}

// ------------------------------------------------------------------------------ propeller laws

double Actuator::ctAt(double rpm) const {
  const PropellerParams& q = p_.prop;
  return lerpClamped(rpm, q.rpm_low, q.rpm_high, q.ct_low, q.ct_high);
}

double Actuator::cpAt(double rpm) const {
  const PropellerParams& q = p_.prop;
  return lerpClamped(rpm, q.rpm_low, q.rpm_high, q.cp_low, q.cp_high);
}

double Actuator::thrustAt_n(double omega) const {
  const double n = omega / kTwoPi;
  return ctAt(omega * kRadPerSToRpm) * rho_ * n * n * d4_;
}

double Actuator::torqueAt_nm(double omega) const {
  const double n = omega / kTwoPi;
  return cpAt(omega * kRadPerSToRpm) * rho_ * n * n * d5_ / kTwoPi;
}

double Actuator::ke_v_s_per_rad() const {
  return ke25_ * (1.0 + p_.motor.flux_tempco_per_k * (winding_temp_c_ - 25.0));
}

double Actuator::resistance_ohm() const {
  return p_.motor.r_winding_ohm * (1.0 + p_.motor.r_tempco_per_k * (winding_temp_c_ - 25.0)) +
         p_.esc.r_esc_ohm;
}

// ------------------------------------------------------------------------------ time stepping

BusLoad Actuator::busLoad() const {
  const double d = duty();
  BusLoad load{0.0, p_.esc.idle_current_a};
  if (d <= 0.0) return load;
  const double r = resistance_ohm();
  const double back_emf = ke_v_s_per_rad() * omega_;
  // Conducting if the drive voltage at the last bus voltage exceeds the back-EMF.
  if (d * last_bus_v_ > back_emf || omega_ == 0.0) {
    load.conductance_s = d * d / r;
    load.offset_a -= d * back_emf / r;
  }
  return load;
}

double Actuator::step(double dt_s, double bus_v) {
  time_s_ += dt_s;
  last_bus_v_ = bus_v;
  const EscParams& e = p_.esc;
  if (armed_ && !hold_ && time_s_ - last_pulse_t_s_ > e.timeout_s) {
    armed_ = false;  // signal lost: stop, re-arming needed
    arm_since_s_ = -1.0;
  }
  if (bus_v < e.min_bus_v) {
    armed_ = false;  // brown-out
    arm_since_s_ = -1.0;
  }
  const double d = duty();
  const double ke = ke_v_s_per_rad();
  const double r = resistance_ohm();
  const double u = d * bus_v;
  double current = 0.0;
  if (d > 0.0) current = std::max(0.0, (u - ke * omega_) / r);

  // Net torque and its derivative with respect to omega (linearly implicit Euler).
  const double drag = torqueAt_nm(omega_);
  const double friction = ke * p_.motor.i0_a * std::min(1.0, omega_ / kFrictionFadeRadPerS);
  const double accel = (ke * current - friction - drag) / inertia_;
  double daccel = -2.0 * drag / std::max(omega_, 1e-9);
  if (current > 0.0) daccel -= ke * ke / r;
  if (omega_ < kFrictionFadeRadPerS) daccel -= ke * p_.motor.i0_a / kFrictionFadeRadPerS;
  daccel /= inertia_;
  omega_ = std::max(0.0, omega_ + dt_s * accel / (1.0 - dt_s * daccel));

  // Winding temperature (copper losses in the winding only; the ESC's share heats the ESC).
  const MotorParams& m = p_.motor;
  const double r_winding = m.r_winding_ohm * (1.0 + m.r_tempco_per_k * (winding_temp_c_ - 25.0));
  const double heat_w = current * current * r_winding;
  const double loss_w = (winding_temp_c_ - env_.temp_c) / m.thermal_resistance_k_per_w;
  winding_temp_c_ += dt_s * (heat_w - loss_w) / m.heat_capacity_j_per_k;

  motor_current_a_ = current;
  bus_current_a_ = d * current + e.idle_current_a;
  return bus_current_a_;
}

double Actuator::thrust_n() const { return thrustAt_n(omega_); }
double Actuator::thrust_g() const { return thrustAt_n(omega_) * kNewtonToGram; }
double Actuator::torque_nm() const { return torqueAt_nm(omega_); }
double Actuator::rpm() const { return omega_ * kRadPerSToRpm; }
void Actuator::setSpeed_rpm(double rpm) { omega_ = std::max(0.0, rpm / kRadPerSToRpm); }

// ------------------------------------------------------------------------------- steady state

double Actuator::omegaSteady(double u_v, double ke, double r) const {
  const double i0 = p_.motor.i0_a;
  if (u_v / r <= i0) return 0.0;  // cannot overcome friction
  // g(w) = Kt ((u - Ke w) / R - I0) - Q(w) falls monotonically from > 0 at 0 to < 0 at u/Ke.
  // The Illinois variant of regula falsi: the root stays bracketed as in a bisection, and it
  // converges superlinearly (about ten torque evaluations to 1e-12 instead of eighty).
  auto g = [&](double w) { return ke * ((u_v - ke * w) / r - i0) - torqueAt_nm(w); };
  double lo = 0.0, hi = u_v / ke;
  double g_lo = g(lo), g_hi = g(hi);
  int kept = 0;  // which end stayed last time: -1 lo, +1 hi
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = (lo * g_hi - hi * g_lo) / (g_hi - g_lo);
    const double g_mid = g(mid);
    if (g_mid == 0.0) return mid;
    if (g_mid > 0.0) {
      lo = mid;
      g_lo = g_mid;
      if (kept == +1) g_hi *= 0.5;
      kept = +1;
    } else {
      hi = mid;
      g_hi = g_mid;
      if (kept == -1) g_lo *= 0.5;
      kept = -1;
    }
  }
  return 0.5 * (lo + hi);
}

OperatingPoint Actuator::steadyStateAtDuty(double duty, double bus_v) const {
  OperatingPoint op;
  op.duty = std::clamp(duty, 0.0, 1.0);
  op.pulse_us = p_.esc.start_us + op.duty * (p_.esc.full_us - p_.esc.start_us);
  op.bus_v = bus_v;
  const double ke = ke_v_s_per_rad();
  const double r = resistance_ohm();
  const double u = op.duty * bus_v;
  const double w = omegaSteady(u, ke, r);
  op.rpm = w * kRadPerSToRpm;
  op.thrust_g = thrustAt_n(w) * kNewtonToGram;
  op.torque_nm = torqueAt_nm(w);
  op.motor_current_a = op.duty > 0.0 ? std::max(0.0, (u - ke * w) / r) : 0.0;
  op.bus_current_a = op.duty * op.motor_current_a + p_.esc.idle_current_a;
  return op;
}

OperatingPoint Actuator::steadyState(double pulse_us, double bus_v) const {
  OperatingPoint op = steadyStateAtDuty(dutyForPulse(pulse_us), bus_v);
  op.pulse_us = pulse_us;
  return op;
}

double Actuator::pulseForThrust_us(double thrust_g, double bus_v) const {
  double lo = p_.esc.start_us, hi = p_.esc.full_us;
  if (thrust_g <= 0.0) return lo;
  if (steadyState(hi, bus_v).thrust_g < thrust_g) return hi;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (steadyState(mid, bus_v).thrust_g < thrust_g ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace plant

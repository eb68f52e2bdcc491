// Parameters of one actuator (ESC + BLDC motor + propeller), named presets and per-part
// variation. All quantities carry their unit in the name. Defaults are the thesis's
// T-motor MT2208 KV1100 + APC 9x4.7 SF + HobbyWing Flyfun 18A, tuned so the plant reproduces
// thesis table 5.1 (see plant/fidelity.hpp).
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace plant {

// Propeller, static thrust (no inflow): T = C_T(rpm) rho n^2 D^4, Q = C_P(rpm) rho n^2 D^5 / (2 pi)
// with n in rev/s. C_T and C_P are interpolated linearly in rpm between a low and a high point
// and held constant outside them (UIUC static data: C_T rises with rpm, Reynolds effect).
struct PropellerParams {
  double diameter_m = 0.2286;    // 9 in
  double ct_low = 0.114;         // C_T at rpm_low  (UIUC APC 9x4.7 SF static)
  double ct_high = 0.120;        // C_T at rpm_high
  double cp_low = 0.048;         // C_P at rpm_low
  double cp_high = 0.048;        // C_P at rpm_high
  double rpm_low = 2800.0;
  double rpm_high = 6800.0;
  double inertia_kgm2 = 4.5e-5;  // about the shaft (APC 9x4.7 SF, ~11 g)
  double mass_g = 11.0;
};

// BLDC motor as a DC machine seen from the ESC: Kt = Ke = 60 / (2 pi Kv).
// Winding resistance and magnet flux follow the winding temperature (first-order thermal
// model: heat_capacity dT/dt = I^2 R_winding - (T - T_ambient) / thermal_resistance).
struct MotorParams {
  double kv_rpm_per_v = 1100.0;        // at 25 C
  double r_winding_ohm = 0.100;        // phase-to-phase winding resistance at 25 C
  double i0_a = 0.40;                  // no-load current (friction + iron losses), as torque Kt*I0
  double rotor_inertia_kgm2 = 4.0e-6;  // rotating bell
  double r_tempco_per_k = 0.0039;      // copper: R(T) = R25 (1 + 0.0039 (T - 25))
  double flux_tempco_per_k = -0.001;   // magnets: Ke(T) = Ke25 (1 - 0.001 (T - 25)), so Kv rises
  double heat_capacity_j_per_k = 30.0; // winding + stator + bell
  double thermal_resistance_k_per_w = 4.0;  // to ambient, with the propeller's airflow
  double mass_g = 68.0;
};

// ESC: servo-pulse input, duty d = (pulse - start_us) / (full_us - start_us) clamped to 0..1,
// motor voltage d * V_bus (the motor sees an averaged buck converter), bus current d * I.
// Arming: after power-up (or a timeout) it needs pulses <= arm_max_us for arm_time_s before
// it drives the motor. Pulses narrower than min_pulse_us or wider than max_pulse_us, or
// arriving faster than max_frame_hz, are ignored (noise). No valid pulse for timeout_s:
// motor off and disarmed (re-arming needed). The motor current cannot reverse (no active
// braking: when the back-EMF exceeds d * V the motor coasts down on propeller drag).
struct EscParams {
  double start_us = 1097.0;     // duty 0 (no thrust below this; thesis: "about 1080 us")
  double full_us = 1920.0;      // duty 1
  double r_esc_ohm = 0.050;     // FETs + ESC and motor leads (not temperature dependent here)
  double idle_current_a = 0.03; // ESC electronics, also when the motor stands
  double arm_max_us = 1060.0;
  double arm_time_s = 1.0;
  double timeout_s = 0.25;
  double min_pulse_us = 800.0;
  double max_pulse_us = 2200.0;
  double max_frame_hz = 500.0;  // accepts 50..490 Hz servo frames
  double min_bus_v = 6.0;       // below this the ESC browns out (disarms, motor off)
};

struct ActuatorParams {
  std::string name = "kv1100_9x4.7";
  MotorParams motor;
  PropellerParams prop;
  EscParams esc;

  // Motor + propeller (+ adapter) weight resting on the load-cell plate, grams.
  double mountWeight_g() const { return motor.mass_g + prop.mass_g + 2.0; }
  double inertia_kgm2() const { return motor.rotor_inertia_kgm2 + prop.inertia_kgm2; }
};

// Datasheet operating point (thesis tables 4.2/4.3: T-motor data at 11.1 V, 75 % throttle).
struct DatasheetPoint {
  double bus_v = 11.1;
  double throttle = 0.75;
  double current_a = 0.0;
  double thrust_g = 0.0;
  double rpm = 0.0;
};

struct Preset {
  ActuatorParams params;
  std::string description;
  DatasheetPoint datasheet;
};

// The thesis's four combinations: "kv1100_9x4.7" (the main one), "kv1100_10x3.8",
// "kv900_10x3.8", "kv900_11x4.7".
const std::vector<Preset>& presets();
// nullopt if the name is unknown (names are case-sensitive; see presets()).
std::optional<Preset> findPreset(const std::string& name);
// Like findPreset but throws std::invalid_argument listing the known names.
ActuatorParams presetParams(const std::string& name);

// A real part out of the box: Kv, winding R, I0, rotor and propeller inertia and the ESC's
// resistance each scaled by (1 + spread * N(0,1)), N clamped to +-3 sigma; C_T and C_P get
// spread/2 and D spread/4 (moulded props are more consistent than wound motors); the ESC's
// start_us moves by N(0, 4 us * spread / 0.03). The name gets "#seed" appended. Deterministic: same (params, seed, spread), same
// result on every machine. spread 0 returns the params unchanged. Typical spread: 0.03.
ActuatorParams makeVaried(const ActuatorParams& base, uint64_t seed, double spread = 0.03);

}  // namespace plant

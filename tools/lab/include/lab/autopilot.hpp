// The thrust models of ArduPilot, PX4 and Betaflight, computed as each autopilot computes them,
// and their least-squares fit to thrust-stand measurements.
//
// Each autopilot linearises thrust with a one-parameter curve between two output endpoints and
// (optionally) scales it with the battery voltage. Here each has two directions:
//   - what the autopilot OUTPUTS for a thrust demand (its own code path, clamps included), and
//   - the force it therefore ASSUMES the motor makes at a PWM and voltage: thrustFraction(),
//     the fraction of the full thrust (at the top endpoint and a full battery). The fit scales
//     it by the full thrust in grams, which no autopilot stores (ArduPilot and PX4 learn the
//     hover thrust instead; --auw-g turns the fitted scale into MOT_THST_HOVER / MPC_THR_HOVER).
//
// Sources, read for this (paths in the autopilots' repositories; the code is not copied here):
//   ArduPilot/ardupilot libraries/AP_Motors/AP_Motors_Thrust_Linearization.cpp
//     @ 04dc0b71a37d744b653ff93ac4d02f8e0487a101 (thrust_to_actuator, actuator_to_thrust,
//     apply/remove_thrust_curve_and_volt_scaling, update_lift_max_from_batt_voltage);
//     libraries/AP_Motors/AP_MotorsMulticopter.cpp @ c1a9f75034fc8f0c64fb9bce9cfa5d42fe24357f
//     (output_to_pwm; MOT_* parameter table).
//   PX4/PX4-Autopilot src/lib/mixer_module/functions/FunctionMotors.hpp
//     @ 15c4f0887da95b50c9b17e2a64dabe42dbd7a683 (updateValues: THR_MDL_FAC);
//     src/lib/mixer_module/mixer_module.cpp @ 36af1d6b2af4616992c61f2dbe2aadb021f56310
//     (output_limit_calc_single); src/lib/battery/battery.cpp
//     @ 03c80917055169e05fa2105c9468d369470bc387 (computeScale); src/modules/mc_rate_control/
//     MulticopterRateControl.cpp (the thrust setpoint times battery_status.scale when
//     MC_BAT_SCALE_EN); src/drivers/pwm_out/module.yaml @ 0085a03d407db7a2b69eed70c03f9a710f91aa97
//     (PWM_MAIN_MINn 800..1400 default 1000, PWM_MAIN_MAXn 1600..2200 default 2000).
//   betaflight/betaflight @ 301d01abc40c2b4cde45a07d86a9c102948ad1f2 (2026-08-22):
//     src/main/flight/pid.c (pidApplyThrustLinearization, pidCompensateThrustLinearization,
//     rewritten in b8cb3203819cb62d6c30a06fc14c542ec2f6d978), pid_init.c (thrust_linear / 100),
//     mixer.c (applyMixToMotors, calculateThrottleAndCurrentMotorEndpoints: sag compensation),
//     mixer_init.c (initEscEndpoints, vbatFull 4.20 V), drivers/pwm_output.c and drivers/dshot.c
//     (motor output endpoints), pg/motor.c (defaults), cli/settings.c (ranges).
#pragma once
#include <cmath>
#include <functional>
#include <string>
#include <vector>

namespace lab::autopilot {

enum class Autopilot { kArduPilot, kPx4, kBetaflight };
// "ardupilot" | "px4" | "betaflight"; throws std::invalid_argument naming the choices.
Autopilot parseAutopilot(const std::string& name);
const char* autopilotName(Autopilot a);  // "ArduPilot", "PX4", "Betaflight"

// ---- ArduPilot -------------------------------------------------------------------------------

struct ArduPilotParams {
  double thst_expo = 0.65;      // MOT_THST_EXPO (clamped to -1..1 by the code)
  double spin_min = 0.15;       // MOT_SPIN_MIN: where thrust starts, fraction of the PWM range
  double spin_max = 0.95;       // MOT_SPIN_MAX: where thrust saturates
  double pwm_min_us = 1000;     // MOT_PWM_MIN
  double pwm_max_us = 2000;     // MOT_PWM_MAX
  double bat_volt_max_v = 0;    // MOT_BAT_VOLT_MAX (0: voltage compensation off)
  double bat_volt_min_v = 0;    // MOT_BAT_VOLT_MIN
};

namespace ardupilot {
// update_lift_max_from_batt_voltage() in steady state (its 0.5 Hz filter settled): the
// filtered ratio clamp(V, max(V_MIN, 0.6 V_MAX), V_MAX) / V_MAX, or 1 when compensation is
// off (V_MAX <= 0, V_MIN >= V_MAX, the voltage below a quarter of V_MIN, or not logged: NaN).
double voltageRatio(const ArduPilotParams& p, double vbat_v);
// lift_max = v (1 - e) + e v^2: the full thrust available at this voltage, as a fraction of the
// full thrust at V_MAX.
double liftMax(const ArduPilotParams& p, double vbat_v);
double applyThrustCurveAndVoltScaling(const ArduPilotParams& p, double thrust, double vbat_v);
double removeThrustCurveAndVoltScaling(const ArduPilotParams& p, double throttle, double vbat_v);
// thrust_to_actuator(): thrust demand 0..1 (of lift_max) -> actuator 0..1 of the PWM range.
double thrustToActuator(const ArduPilotParams& p, double thrust, double vbat_v);
// actuator_to_thrust(): ArduPilot's own inverse, clamped to 0..1. Note: below SPIN_MIN it is
// not 0 for every expo (its quadratic turns up again, e.g. expo 0.95 at 1100 us of
// 1000-2000); thrustFraction() uses 0 there, which is what SPIN_MIN means.
double actuatorToThrust(const ArduPilotParams& p, double actuator, double vbat_v);
// output_to_pwm() in every spool state but SHUT_DOWN: PWM_MIN + (PWM_MAX - PWM_MIN) *
// actuator, converted to int16 as the code returns it (truncated toward zero).
int outputToPwm(const ArduPilotParams& p, double actuator);
// The PWM ArduPilot sends for a force of `fraction` of the full thrust at V_MAX (its
// get_throttle(); the compensation gain 1 / lift_max applied as output_armed_stabilizing does).
int pwmForThrust(const ArduPilotParams& p, double fraction, double vbat_v);
// The force ArduPilot assumes at a PWM, as a fraction of the full thrust at V_MAX:
// lift_max * actuator_to_thrust(actuator), i.e. e y^2 + (1 - e) y with y = t v,
// t = clamp((actuator - SPIN_MIN) / (SPIN_MAX - SPIN_MIN), 0, 1), actuator = (pwm - PWM_MIN) /
// (PWM_MAX - PWM_MIN); 0 at and below SPIN_MIN.
double thrustFraction(const ArduPilotParams& p, double pwm_us, double vbat_v);
}  // namespace ardupilot

// ---- PX4 -------------------------------------------------------------------------------------

struct Px4Params {
  double thr_mdl_fac = 0;        // THR_MDL_FAC: rel_thrust = f x^2 + (1 - f) x
  double pwm_min_us = 1000;      // PWM_MAIN_MINn
  double pwm_max_us = 2000;      // PWM_MAIN_MAXn
  double pwm_disarmed_us = 1000; // PWM_MAIN_DISn
  bool bat_scale_en = false;     // MC_BAT_SCALE_EN
  double bat_v_charged = 4.05;   // BATn_V_CHARGED, per cell (PX4's default)
  int bat_n_cells = 0;           // BATn_N_CELLS
};

namespace px4 {
// Battery::computeScale() in steady state: V_CHARGED / V_cell constrained to 1..1.3 (1 when
// not finite; the load term R * I is taken as part of the logged voltage, see docs).
double batteryScale(const Px4Params& p, double vbat_v);
// FunctionMotors::updateValues() for one non-reversible motor: the thrust setpoint (after
// allocation) -> the output value in -1..1; NaN (disarmed output) for a negative setpoint.
// THR_MDL_FAC outside (FLT_EPSILON, 1] leaves the setpoint linear.
double thrustToOutput(const Px4Params& p, double thrust);
// MixingOutput::output_limit_calc_single() in the ON state: -1..1 -> MIN..MAX (clamped),
// rounded (lroundf); NaN -> the disarmed value.
int outputToPwm(const Px4Params& p, double value);
// The PWM PX4 sends for a collective thrust setpoint (0..1 of full thrust): times the battery
// scale when MC_BAT_SCALE_EN (constrained to -1..1 as the rate controller does), then the two
// functions above.
int pwmForThrust(const Px4Params& p, double thrust_setpoint, double vbat_v);
// The force PX4 assumes at a PWM, as a fraction of full thrust: (f x^2 + (1 - f) x) / scale,
// x = clamp((pwm - MIN) / (MAX - MIN), 0, 1).
double thrustFraction(const Px4Params& p, double pwm_us, double vbat_v);
}  // namespace px4

// ---- Betaflight ------------------------------------------------------------------------------

enum class BfProtocol { kDshot, kPwm };

struct BetaflightParams {
  int thrust_linear = 0;          // thrust_linear 0..150 (pidRuntime value = /100)
  int motor_idle = 550;           // motor_idle, 0.01 % of the range (550 = 5.5 %)
  int motor_output_limit = 100;   // motor_output_limit, 1..100 %
  int vbat_sag_compensation = 0;  // vbat_sag_compensation, 0..150 %
  BfProtocol protocol = BfProtocol::kDshot;
  int min_command = 1000;         // min_command (PWM protocols; with DShot: the stand ESC's range)
  int max_throttle = 2000;        // max_throttle (PWM protocols; with DShot: the stand ESC's range)
  int vbat_warning_cell_cv = 350; // vbatwarningcellvoltage, 0.01 V per cell
  int cells = 0;                  // battery cell count (detected by the FC; needed for sag comp)
};

namespace betaflight {
// Above this thrust_linear the curve below stops rising with x (its slope 5/6 - e^2/2 turns
// negative near x = 0.5 + 1/(6e)): 129.
constexpr int kMonotoneThrustLinearMax = 129;
// pidApplyThrustLinearization(): c(x) = x (1 + e (1 - x) (1 + e (1 - 2x))), e = thrust_linear/100.
double applyThrustLinearization(int thrust_linear, double motor_output);
// pidCompensateThrustLinearization(): throttle * (1 - e (1 - throttle)) (e != 0).
double compensateThrustLinearization(int thrust_linear, double throttle);
// The inverse of applyThrustLinearization on 0..1 (bisection; thrust_linear <= 129).
double removeThrustLinearization(int thrust_linear, double motor_output);
struct Endpoints {
  double low = 0, high = 0;  // motorOutputLow / motorOutputHigh, in protocol units
};
// motorInitEndpoints() without 3D: analogInitEndpoints (PWM: low = min_command + idle * 0.1,
// high = max_throttle - (max_throttle - low) (1 - limit)) or dshotInitEndpoints (DShot: low =
// 48 + idle% * 1999, high = 2047 - 1999 (1 - limit)).
Endpoints endpoints(const BetaflightParams& p);
// motorRangeMax with vbat_sag_compensation (calculateThrottleAndCurrentMotorEndpoints): high
// minus (range / 4.20 V) * goodness * comp * (high - low), goodness from the sag-filtered cell
// voltage (0.01 V, integer division by the cell count as getBatterySagCellVoltage returns it).
double rangeMax(const BetaflightParams& p, double vbat_v);
// applyMixToMotors() for a pure throttle demand x (0..1, no roll/pitch/yaw): the motor value
// in protocol units, constrained to motorRangeMin..motorRangeMax.
double motorOutput(const BetaflightParams& p, double x, double vbat_v);
// A protocol value as the pulse that gives the same throttle on the thrust stand's ESC, whose
// calibrated range is min_command..max_throttle (DShot 48..2047 -> 1000..2000 us by default);
// PWM values pass through.
double toPulseUs(const BetaflightParams& p, double value);
double fromPulseUs(const BetaflightParams& p, double pwm_us);
// The force Betaflight assumes at a pulse, as a fraction of full thrust: its mixer's linear
// thrust demand x with motorOutput(x) = that pulse, clamped to 0..1 (thrust_linear <= 129).
double thrustFraction(const BetaflightParams& p, double pwm_us, double vbat_v);
}  // namespace betaflight

// ---- Fitting ---------------------------------------------------------------------------------

// One measurement: the ESC pulse, the force, the battery voltage (NaN when not logged) and a
// weight (1 for plain least squares in grams; 1/force^2 makes it relative).
struct Row {
  double pwm_us = 0;
  double force_g = 0;
  double vbat_v = NAN;
  double weight = 1;
};

// The best scale of a model for rows: force ~ full_g * fraction(row), weighted least squares.
struct Scaled {
  double full_g = 0;   // full thrust (g): the force at the top endpoint on a full battery
  double rss = 0;      // weighted residual sum of squares
};
Scaled bestScale(const std::vector<Row>& rows, const std::function<double(const Row&)>& fraction);

// What the fit may choose and what it keeps; the defaults are each autopilot's.
struct FitSetup {
  double esc_min_us = 1000, esc_max_us = 2000;  // the ESC's calibrated range (MOT_PWM_MIN/MAX,
                                                 // Betaflight's min_command/max_throttle)
  int cells = 0;                 // battery cells (0: no voltage compensation)
  double bat_volt_min_per_cell = 3.3;  // ArduPilot MOT_BAT_VOLT_MIN per cell (its docs' value;
                                       // the code raises anything below 0.6 * MOT_BAT_VOLT_MAX)
  bool use_voltage = true;       // false: the voltage column is ignored (or absent)
  bool fit_spin_max = true;      // ArduPilot: search MOT_SPIN_MAX in 0.9..1, else keep 0.95
  double px4_v_charged = 4.05;   // PX4 BATn_V_CHARGED per cell
  BfProtocol bf_protocol = BfProtocol::kDshot;
  int bf_vbat_warning_cell_cv = 350;
};

struct ArduPilotFit {
  ArduPilotParams params;
  Scaled scale;
  std::vector<std::string> notes;
};
// Fits MOT_THST_EXPO (-1..1), MOT_SPIN_MIN (0..0.3) and MOT_SPIN_MAX (0.9..1, ties go to 0.95)
// with MOT_PWM_MIN/MAX = the ESC range and, when the rows have voltages and setup.cells > 0,
// MOT_BAT_VOLT_MAX/MIN = 4.2 / setup.bat_volt_min_per_cell V per cell (the parameter docs
// recommend 4.2 / 3.3). For fixed
// SPIN_MIN/MAX the force is linear in (full_g (1 - e), full_g e): solved exactly, e constrained.
// Throws std::invalid_argument when fewer than 3 rows carry weight.
ArduPilotFit fitArduPilot(const std::vector<Row>& rows, const FitSetup& setup);

struct Px4Fit {
  Px4Params params;
  Scaled scale;
  std::vector<std::string> notes;
};
// Fits THR_MDL_FAC (0..1), PWM_MAIN_MIN (800..1400) and PWM_MAIN_MAX (1600..2200, no higher
// than the ESC's top; ties go to the ESC's top), integers in microseconds as PX4 stores them.
// `bat_scale`: with MC_BAT_SCALE_EN = 1 (needs voltages and cells).
Px4Fit fitPx4(const std::vector<Row>& rows, const FitSetup& setup, bool bat_scale);

struct BetaflightFit {
  BetaflightParams params;
  Scaled scale;
  std::vector<std::string> notes;
};
// Fits thrust_linear (0..129), motor_idle (0..2000), motor_output_limit (50..100, ties go to
// 100) and, with voltages and cells, vbat_sag_compensation (0..150, ties go to 0); integers as
// Betaflight stores them.
BetaflightFit fitBetaflight(const std::vector<Row>& rows, const FitSetup& setup);

}  // namespace lab::autopilot

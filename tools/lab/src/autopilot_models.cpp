// The three autopilots' thrust paths, as their sources compute them (paths and commits in
// lab/autopilot.hpp). Written from the formulas in those files, not copied: single-precision
// details that change a result are reproduced (ArduPilot's is_zero / is_positive against
// FLT_EPSILON, the int16 truncation of output_to_pwm, PX4's lroundf, Betaflight's integer cell
// voltage); everything else is double.
#include <algorithm>
#include <cfloat>
#include <cstdint>
#include <cmath>
#include <stdexcept>

#include "lab/autopilot.hpp"

namespace lab::autopilot {

namespace {

double clampd(double v, double lo, double hi) { return std::min(std::max(v, lo), hi); }

// AP_Math: is_zero(x) is |x| < FLT_EPSILON, is_positive(x) is x >= FLT_EPSILON, safe_sqrt
// returns 0 where sqrt would be NaN.
bool isZero(double x) { return std::fabs(x) < FLT_EPSILON; }
bool isPositive(double x) { return x >= FLT_EPSILON; }
double safeSqrt(double v) {
  const double r = std::sqrt(v);
  return std::isnan(r) ? 0.0 : r;
}

}  // namespace

Autopilot parseAutopilot(const std::string& name) {
  if (name == "ardupilot") return Autopilot::kArduPilot;
  if (name == "px4") return Autopilot::kPx4;
  if (name == "betaflight") return Autopilot::kBetaflight;
  throw std::invalid_argument("--to " + name + ": choose ardupilot, px4 or betaflight");
}

const char* autopilotName(Autopilot a) {
  switch (a) {
    case Autopilot::kArduPilot: return "ArduPilot";
    case Autopilot::kPx4: return "PX4";
    case Autopilot::kBetaflight: return "Betaflight";
  }
  return "?";
}

// ---- ArduPilot -------------------------------------------------------------------------------

namespace ardupilot {

namespace {
double expoOf(const ArduPilotParams& p) { return clampd(p.thst_expo, -1.0, 1.0); }
// 1 / batt_voltage_filt when it is positive, else 1 (apply/remove_thrust_curve_and_volt_scaling).
double batteryScale(double v) { return isPositive(v) ? 1.0 / v : 1.0; }
}  // namespace

double voltageRatio(const ArduPilotParams& p, double vbat_v) {
  const double vmax = p.bat_volt_max_v;
  // batt_voltage_min is raised to 0.6 V_MAX on the first update and stays raised; the steady
  // state sees the raised value in every check.
  const double vmin = std::max(p.bat_volt_min_v, 0.6 * vmax);
  if (!(vmax > 0) || p.bat_volt_min_v >= vmax || !std::isfinite(vbat_v) || vbat_v < 0.25 * vmin) return 1.0;
  return clampd(vbat_v, vmin, vmax) / vmax;
}

double liftMax(const ArduPilotParams& p, double vbat_v) {
  const double v = voltageRatio(p, vbat_v);
  const double e = expoOf(p);
  return v * (1 - e) + e * v * v;
}

double applyThrustCurveAndVoltScaling(const ArduPilotParams& p, double thrust, double vbat_v) {
  const double bs = batteryScale(voltageRatio(p, vbat_v));
  const double lift = liftMax(p, vbat_v);
  const double e = expoOf(p);
  if (isZero(e)) return lift * thrust * bs;  // linear; the code does not clamp this branch
  const double ratio = ((e - 1.0) + safeSqrt((1.0 - e) * (1.0 - e) + 4.0 * e * lift * thrust)) / (2.0 * e);
  return clampd(ratio * bs, 0.0, 1.0);
}

double removeThrustCurveAndVoltScaling(const ArduPilotParams& p, double throttle, double vbat_v) {
  const double bs = batteryScale(voltageRatio(p, vbat_v));
  const double lift = liftMax(p, vbat_v);
  const double e = expoOf(p);
  if (isZero(e)) return throttle / (lift * bs);
  double thrust = ((throttle / bs) * (2.0 * e)) - (e - 1.0);
  thrust = (thrust * thrust) - ((1.0 - e) * (1.0 - e));
  thrust /= 4.0 * e * lift;
  return clampd(thrust, 0.0, 1.0);
}

double thrustToActuator(const ArduPilotParams& p, double thrust, double vbat_v) {
  thrust = clampd(thrust, 0.0, 1.0);
  return p.spin_min + (p.spin_max - p.spin_min) * applyThrustCurveAndVoltScaling(p, thrust, vbat_v);
}

double actuatorToThrust(const ArduPilotParams& p, double actuator, double vbat_v) {
  actuator = (actuator - p.spin_min) / (p.spin_max - p.spin_min);
  return clampd(removeThrustCurveAndVoltScaling(p, actuator, vbat_v), 0.0, 1.0);
}

int outputToPwm(const ArduPilotParams& p, double actuator) {
  const float pwm = static_cast<float>(p.pwm_min_us + (p.pwm_max_us - p.pwm_min_us) * actuator);
  return static_cast<int16_t>(pwm);  // int16_t return: truncation toward zero
}

int pwmForThrust(const ArduPilotParams& p, double fraction, double vbat_v) {
  const double lift = liftMax(p, vbat_v);
  const double gain = lift > 0 ? 1.0 / lift : 1.0;  // get_compensation_gain() (no air density)
  return outputToPwm(p, thrustToActuator(p, fraction * gain, vbat_v));
}

double thrustFraction(const ArduPilotParams& p, double pwm_us, double vbat_v) {
  const double actuator = (pwm_us - p.pwm_min_us) / (p.pwm_max_us - p.pwm_min_us);
  if (!(actuator > p.spin_min)) return 0.0;
  return liftMax(p, vbat_v) * actuatorToThrust(p, actuator, vbat_v);
}

}  // namespace ardupilot

// ---- PX4 -------------------------------------------------------------------------------------

namespace px4 {

namespace {
bool facActive(double f) { return f > FLT_EPSILON && f <= 1.0; }
void orderedRange(const Px4Params& p, double& lo, double& hi) {
  // MixingOutput::updateParams swaps MIN and MAX when MIN > MAX
  lo = std::min(p.pwm_min_us, p.pwm_max_us);
  hi = std::max(p.pwm_min_us, p.pwm_max_us);
}
}  // namespace

double batteryScale(const Px4Params& p, double vbat_v) {
  if (p.bat_n_cells <= 0 || !std::isfinite(vbat_v)) return 1.0;  // no cell voltage: scale 1
  const double scale = p.bat_v_charged / (vbat_v / p.bat_n_cells);
  return std::isfinite(scale) ? clampd(scale, 1.0, 1.3) : 1.0;
}

double thrustToOutput(const Px4Params& p, double thrust) {
  double value = thrust;
  if (facActive(p.thr_mdl_fac) && std::isfinite(thrust)) {
    const double a = p.thr_mdl_fac, b = 1.0 - p.thr_mdl_fac;
    const double tmp1 = b / (2.0 * a), tmp2 = b * b / (4.0 * a * a);
    if (thrust > FLT_EPSILON)
      value = -tmp1 + std::sqrt(tmp2 + thrust / a);
    else if (thrust < -FLT_EPSILON)
      value = tmp1 - std::sqrt(tmp2 - thrust / a);
  }
  if (value < -FLT_EPSILON) return NAN;  // non-reversible motor: negative -> disarmed
  return value * 2.0 - 1.0;              // [0, 1] -> [-1, 1]
}

int outputToPwm(const Px4Params& p, double value) {
  if (!std::isfinite(value)) return static_cast<int>(std::lround(p.pwm_disarmed_us));
  double lo, hi;
  orderedRange(p, lo, hi);
  // math::interpolate(value, -1, 1, min, max) clamps outside -1..1
  const double out = value <= -1.0 ? lo : value >= 1.0 ? hi : lo + (value + 1.0) * 0.5 * (hi - lo);
  return static_cast<int>(clampd(static_cast<double>(std::lround(static_cast<float>(out))), 0.0, 65535.0));
}

int pwmForThrust(const Px4Params& p, double thrust_setpoint, double vbat_v) {
  double t = thrust_setpoint;
  if (p.bat_scale_en) t = clampd(t * batteryScale(p, vbat_v), -1.0, 1.0);
  return outputToPwm(p, thrustToOutput(p, t));
}

double thrustFraction(const Px4Params& p, double pwm_us, double vbat_v) {
  double lo, hi;
  orderedRange(p, lo, hi);
  const double x = hi > lo ? clampd((pwm_us - lo) / (hi - lo), 0.0, 1.0) : 0.0;
  const double f = p.thr_mdl_fac;
  double rel = facActive(f) ? f * x * x + (1.0 - f) * x : x;
  if (p.bat_scale_en) rel /= batteryScale(p, vbat_v);
  return rel;
}

}  // namespace px4

// ---- Betaflight ------------------------------------------------------------------------------

namespace betaflight {

namespace {
constexpr double kDshotMin = 48, kDshotMax = 2047, kDshotRange = kDshotMax - kDshotMin;
constexpr double kCellFullCv = 420;  // CELL_VOLTAGE_FULL_CV
double linearization(int thrust_linear) { return static_cast<float>(thrust_linear) / 100.0f; }
double outputLimit(const BetaflightParams& p) {
  return p.motor_output_limit < 100 ? p.motor_output_limit / 100.0 : 1.0;
}
}  // namespace

double applyThrustLinearization(int thrust_linear, double motor_output) {
  const double e = linearization(thrust_linear);
  const double inv = 1.0 - motor_output;
  return motor_output * (1.0 + e * inv * (1.0 + e * (inv - motor_output)));
}

double compensateThrustLinearization(int thrust_linear, double throttle) {
  const double e = linearization(thrust_linear);
  if (e != 0.0) throttle *= 1.0 - e * (1.0 - throttle);
  return throttle;
}

double removeThrustLinearization(int thrust_linear, double motor_output) {
  const double target = clampd(motor_output, 0.0, 1.0);
  const double e = linearization(thrust_linear);
  double lo = 0.0, hi = 1.0, x = target;
  for (int i = 0; i < 60; ++i) {
    const double f = applyThrustLinearization(thrust_linear, x) - target;
    if (std::fabs(f) < 1e-13) break;
    if (f > 0) hi = x; else lo = x;
    // Newton step inside the bracket, else bisection
    const double u = x - 0.5;
    const double slope = 1.0 - 2.0 * e * u + e * e * (6.0 * u * u - 0.5);
    double next = slope > 0 ? x - f / slope : -1.0;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    x = next;
  }
  return x;
}

Endpoints endpoints(const BetaflightParams& p) {
  Endpoints e;
  const double limit = outputLimit(p);
  if (p.protocol == BfProtocol::kPwm) {
    const double min_throttle = p.min_command + p.motor_idle * 0.1;
    e.low = min_throttle;
    e.high = p.max_throttle - ((p.max_throttle - min_throttle) * (1.0 - limit));
  } else {
    const double idle = 0.01 * (p.motor_idle * 0.01);  // CONVERT_PARAMETER_TO_PERCENT: a fraction
    e.low = kDshotMin + idle * kDshotRange;
    e.high = kDshotMax - kDshotRange * (1.0 - limit);
  }
  return e;
}

double rangeMax(const BetaflightParams& p, double vbat_v) {
  const Endpoints ep = endpoints(p);
  const double range_cv = kCellFullCv - p.vbat_warning_cell_cv;  // vbatRangeToCompensate
  if (p.vbat_sag_compensation <= 0 || !(range_cv > 0)) return ep.high;
  // getBatterySagCellVoltage(): sagFiltered (0.01 V) / cell count, integer division; 0 without cells
  double cell_cv = 0;
  if (p.cells > 0 && std::isfinite(vbat_v) && vbat_v > 0)
    cell_cv = static_cast<double>(static_cast<long>(std::lround(vbat_v * 100.0)) / p.cells);
  const double goodness = 1.0 - clampd((kCellFullCv - cell_cv) / range_cv, 0.0, 1.0);
  const double factor = (range_cv / kCellFullCv) * goodness * (p.vbat_sag_compensation / 100.0);
  return ep.high - factor * (ep.high - ep.low);
}

double motorOutput(const BetaflightParams& p, double x, double vbat_v) {
  const double low = endpoints(p).low;  // motorRangeMin = motorOutputMin (no dynamic idle)
  const double high = rangeMax(p, vbat_v);
  const double out = low + (high - low) * applyThrustLinearization(p.thrust_linear, x);
  return clampd(out, low, high);
}

double toPulseUs(const BetaflightParams& p, double value) {
  if (p.protocol == BfProtocol::kPwm) return value;
  return p.min_command + (p.max_throttle - p.min_command) * (value - kDshotMin) / kDshotRange;
}

double fromPulseUs(const BetaflightParams& p, double pwm_us) {
  if (p.protocol == BfProtocol::kPwm) return pwm_us;
  return kDshotMin + (pwm_us - p.min_command) * kDshotRange / (p.max_throttle - p.min_command);
}

double thrustFraction(const BetaflightParams& p, double pwm_us, double vbat_v) {
  const double low = endpoints(p).low;
  const double high = rangeMax(p, vbat_v);
  if (!(high > low)) return 0.0;
  const double a = (fromPulseUs(p, pwm_us) - low) / (high - low);
  if (!(a > 0)) return 0.0;
  return removeThrustLinearization(p.thrust_linear, std::min(a, 1.0));
}

}  // namespace betaflight

}  // namespace lab::autopilot

// What the swap experiment's modes without per-motor records fly on (sim/swap.hpp), found from the
// stock motors' calibration sweeps as their users would find them, and the motors' time
// constants, which no static calibration changes.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "lab/autopilot_export.hpp"
#include "lab/dataset.hpp"
#include "plant/actuator.hpp"
#include "plant/environment.hpp"
#include "plant/fidelity.hpp"
#include "sim/swap.hpp"

namespace sim::swap {

namespace {

constexpr double kSlopeHalfSpanUs = 40;  // the force per us: a line through the sweep's steps +-40 us

struct HoverPoint {
  double pulse_us = 0, slope_g_per_us = 0;
};

// Where one up-sweep (gather_store's CSV) crosses `force_g`, and its force per us there.
HoverPoint hoverOnSweep(const std::string& path, double force_g) {
  const lab::Dataset d = lab::readFile(path, lab::ReadOptions{});
  std::vector<std::pair<double, double>> pts;  // pwm, force
  for (std::size_t i = 0; i < d.rows(); ++i)
    if (!d.has("dir") || d.col("dir")[i] > 0) pts.emplace_back(d.col("pwm_us")[i], d.col("force_g")[i]);
  std::sort(pts.begin(), pts.end());
  HoverPoint h;
  for (std::size_t i = 1; i < pts.size() && h.pulse_us == 0; ++i)
    if (pts[i - 1].second < force_g && pts[i].second >= force_g)
      h.pulse_us = pts[i - 1].first + (pts[i].first - pts[i - 1].first) * (force_g - pts[i - 1].second) /
                                          (pts[i].second - pts[i - 1].second);
  if (h.pulse_us == 0)
    throw std::runtime_error(fmt::format(
        "{}: the sweep never crosses {:.0f} g; the motor cannot hover this frame", path, force_g));
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0;
  for (const auto& [p, f] : pts)
    if (std::fabs(p - h.pulse_us) <= kSlopeHalfSpanUs) sx += p, sy += f, sxx += p * p, sxy += p * f, ++n;
  if (n < 3)
    throw std::runtime_error(
        fmt::format("{}: too few steps around {:.0f} us for the slope", path, h.pulse_us));
  h.slope_g_per_us = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  return h;
}

double paramOf(const lab::autopilot::ExportReport& r, const std::string& name) {
  for (const auto& [n, v] : r.params)
    if (n == name) return std::stod(v);
  throw std::runtime_error("the ArduPilot fit wrote no " + name);
}

// A sweep up to where its force stops rising (within 1 % of its largest): above that the bench,
// not the motor, sets the force (the amplifier's top on the LiPo, the 10 V supply's current
// limit), and `lab export` itself advises fitting below it.
lab::Dataset risingPart(const std::string& path) {
  const lab::Dataset d = lab::readFile(path, lab::ReadOptions{});
  const std::vector<double>& pwm = d.col("pwm_us");
  const std::vector<double>& force = d.col("force_g");
  double top = 0;
  for (double f : force) top = std::max(top, f);
  double stop_us = 1e9;
  for (std::size_t i = 0; i < force.size() && stop_us == 1e9; ++i)
    if (force[i] >= 0.99 * top) stop_us = pwm[i];
  std::vector<bool> keep(d.rows());
  for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = pwm[i] < stop_us;
  return d.subset(keep);
}

// `lab export --to ardupilot` on the stock sweeps' rising parts, as fly's console takes it
// (docs/fly.md).
void arduPilotFit(const std::vector<std::string>& sweeps, ModeSettings& m) {
  lab::Dataset data;
  for (const std::string& path : sweeps) {
    const lab::Dataset part = risingPart(path);
    if (data.rows() == 0)
      data = part;
    else
      data.append(part);
  }
  lab::autopilot::ExportOptions eo;
  eo.to = "ardupilot";
  eo.command_line = "thrustcal sim swap (in process: lab export --to ardupilot on the stock sweeps)";
  const lab::autopilot::ExportReport r = lab::autopilot::buildExport(data, eo);
  m.ardupilot_params = r.params;
  m.ardupilot_full_g = r.full_g;
  double ss = 0;
  for (std::size_t i = 0; i < r.rows.size(); ++i)
    ss += std::pow(r.rows[i].force_g - r.models.front().predicted_g[i], 2);
  m.ardupilot_rows = r.rows.size();
  m.ardupilot_rms_g = r.rows.empty() ? 0 : std::sqrt(ss / static_cast<double>(r.rows.size()));
  auto e4 = [](double v) { return static_cast<long>(std::lround(v * 1e4)); };
  auto mv = [](double v) { return static_cast<long>(std::lround(v * 1e3)); };
  m.ardupilot_lines = {
      fmt::format("ap {} {} {} {}", e4(paramOf(r, "MOT_THST_EXPO")), e4(paramOf(r, "MOT_SPIN_MIN")),
                  e4(paramOf(r, "MOT_SPIN_MAX")), std::lround(r.full_g)),
      fmt::format("apvolt {} {}", mv(paramOf(r, "MOT_BAT_VOLT_MAX")), mv(paramOf(r, "MOT_BAT_VOLT_MIN"))),
      fmt::format("appwm {} {}", std::lround(paramOf(r, "MOT_PWM_MIN")),
                  std::lround(paramOf(r, "MOT_PWM_MAX")))};
}

// The pulse for `force_g` on a motor in steady state at `bus_v` (bisection on the plant).
double pulseFor(const plant::Actuator& a, double force_g, double bus_v) {
  double lo = 1000, hi = 2000;
  for (int i = 0; i < 50; ++i) {
    const double mid = 0.5 * (lo + hi);
    (a.steadyState(mid, bus_v).thrust_g < force_g ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double hoverTau(const plant::ActuatorParams& p, double hover_g, double bus_v) {
  const plant::Actuator a(p, plant::Environment{});
  return plant::stepTimeConstant_s(p, bus_v, pulseFor(a, 0.9 * hover_g, bus_v),
                                   pulseFor(a, 1.1 * hover_g, bus_v));
}

}  // namespace

// pwm: the mean over the stock motors of the LiPo sweep's pulse for hover_g and of its force per
// us there (the thesis's Iqarus flew its hover pulse and table 5.1's slope); ardupilot: the
// lab's fit of all stock sweeps.
ModeSettings modeSettings(const SwapOptions& o, const std::vector<std::string>& stock_sweeps) {
  ModeSettings m;
  double pulse = 0, slope = 0;
  int n = 0;
  for (const std::string& path : stock_sweeps) {
    if (path.find("_curve1.csv") == std::string::npos) continue;
    const HoverPoint h = hoverOnSweep(path, o.hover_g);
    pulse += h.pulse_us, slope += h.slope_g_per_us, ++n;
  }
  if (n == 0)
    throw std::runtime_error("no stock LiPo sweep (gather_slotK_curve1.csv) for the pwm mode's hover point");
  m.hover_us = static_cast<int>(std::lround(pulse / n));
  m.slope_g_per_us = slope / n;
  arduPilotFit(stock_sweeps, m);
  return m;
}

DynamicsReport measureDynamics(const SwapOptions& o) {
  constexpr double kBusV = 12.0;  // a 3S pack under a hover load
  DynamicsReport d;
  for (int i = 0; i < 4; ++i)
    d.stock_tau_s[i] = hoverTau(actuatorOf({kStock, o.stock_preset, o.stock_seeds[i], 1.0, ""}, o.variation),
                                o.hover_g, kBusV);
  for (const std::string& name : o.parts)
    d.parts.push_back({name, hoverTau(actuatorOf(findPart(name), o.variation), o.hover_g, kBusV),
                       d.stock_tau_s[kSwapSlot]});
  return d;
}

}  // namespace sim::swap

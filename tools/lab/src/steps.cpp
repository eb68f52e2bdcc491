#include "lab/steps.hpp"

#include <fmt/format.h>

#include <cmath>
#include <map>

namespace lab {

namespace {

constexpr double kAsymmetryShare = 0.05;  // up and down differ by more than this share ...
constexpr double kAsymmetrySigmas = 2.0;  // ... and by more than this many standard uncertainties

std::string dynamicsText(const MotorDynamics& d) {
  const std::string who = d.motor.empty() ? "" : "motor " + d.motor + ": ";
  const std::string taus = fmt::format("tau_down {:.1f} ± {:.1f} ms, tau_up {:.1f} ± {:.1f} ms, {:.2f}x",
                                       1e3 * d.tau_down_s, 1e3 * d.tau_down_sigma_s, 1e3 * d.tau_up_s,
                                       1e3 * d.tau_up_sigma_s, d.tau_down_s / d.tau_up_s);
  if (d.asymmetry > 0)
    return who + "spin-down is slower than spin-up (" + taus +
           "): the ESC does not brake the motor, only the propeller's drag slows it";
  if (d.asymmetry < 0)
    return who + "spin-down is faster than spin-up (" + taus + "): the ESC brakes actively (or the drive is damped)";
  return who + "spin-up and spin-down alike (" + taus + ")";
}

}  // namespace

std::vector<std::vector<std::size_t>> setpointBlocks(const Dataset& d, std::size_t min_rows) {
  std::vector<std::vector<std::size_t>> out;
  if (!d.has("pwm_us")) return out;
  const auto& pwm = d.col("pwm_us");
  std::map<int, std::vector<std::size_t>> current;  // run -> the block being collected
  auto close = [&](std::vector<std::size_t>& b) {
    if (b.size() >= min_rows) out.push_back(b);
    b.clear();
  };
  for (std::size_t i = 0; i < d.rows(); ++i) {
    auto& b = current[d.run[i]];
    if (!b.empty() && pwm[b.back()] != pwm[i]) close(b);
    b.push_back(i);
  }
  for (auto& [run, b] : current) close(b);
  return out;
}

bool isStepLog(const Dataset& d) {
  if (!d.has("t_s") || d.rows() == 0) return false;
  for (double t : d.col("t_s"))
    if (!std::isfinite(t)) return false;
  std::size_t in_blocks = 0;
  for (const auto& b : setpointBlocks(d)) in_blocks += b.size();
  return 2 * in_blocks >= d.rows();
}

std::vector<MotorDynamics> dynamicsOf(const FitResult& fit) {
  std::map<std::string, MotorDynamics> by_motor;
  for (const auto& p : fit.params) {
    if (p.effect != "lag") continue;
    const bool up = p.name.rfind("tau_up_s", 0) == 0, down = p.name.rfind("tau_down_s", 0) == 0;
    if (!up && !down) continue;
    const std::string tag = up ? "tau_up_s" : "tau_down_s";
    const std::string motor = p.name.size() > tag.size() + 7 ? p.name.substr(tag.size() + 7) : "";  // "_motor_"
    MotorDynamics& d = by_motor[motor];
    d.motor = motor;
    (up ? d.tau_up_s : d.tau_down_s) = p.value;
    (up ? d.tau_up_sigma_s : d.tau_down_sigma_s) = p.sigma;
  }
  std::vector<MotorDynamics> out;
  for (auto& [motor, d] : by_motor) {
    const double diff = d.tau_down_s - d.tau_up_s;
    const double sigma = std::hypot(std::isfinite(d.tau_up_sigma_s) ? d.tau_up_sigma_s : 0.0,
                                    std::isfinite(d.tau_down_sigma_s) ? d.tau_down_sigma_s : 0.0);
    const bool beyond = std::fabs(diff) > kAsymmetrySigmas * sigma &&
                        std::fabs(diff) > kAsymmetryShare * std::min(d.tau_up_s, d.tau_down_s);
    d.asymmetry = beyond ? (diff > 0 ? 1 : -1) : 0;
    d.text = dynamicsText(d);
    out.push_back(d);
  }
  return out;
}

}  // namespace lab

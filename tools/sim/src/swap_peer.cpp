// One flight of a peer in the swap experiment (sim/swap.hpp, sim/peer_profile.hpp): another
// firmware on the gimbal, set up as its profile says, flown from its sticks as its pilot would;
// the same rig, motors, parts, IMU units and figures as fly's flights.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include "hal/board.hpp"
#include "hex/intel_hex.hpp"
#include "sim/rc_input.hpp"
#include "sim/swap.hpp"
#include "swap_flight_parts.hpp"

namespace sim::swap {

namespace {

constexpr double kBackToNeutralS = 0.2;  // neutral sticks between arming and hover
constexpr double kSpoolS = 1.0;          // hover sticks before the level flight is measured
constexpr double kIdleUs = 1100;         // a motor above this pulse is spinning

RcScriptRow row(const PeerProfile& p, double t_s, const std::map<std::string, double>& sticks) {
  RcScriptRow r;
  r.t_s = t_s;
  const std::vector<double> us = p.channelValues(sticks);
  r.count = static_cast<int>(us.size());
  std::copy(us.begin(), us.end(), r.us.begin());
  return r;
}

// The sticks over the flight: neutral from power-up, at boot_s the calibration sticks (if any)
// and the wait after them, arming, neutral, hover, the step.
struct Sticks {
  std::vector<RcScriptRow> rows;
  double t_hover = 0, t_step = 0;
};

Sticks sticksOf(const PeerProfile& p, const SwapOptions& o, const RunSpec& r) {
  Sticks s;
  const bool calibrates = !p.calibrate.empty();
  const double t_arm = p.boot_s + (calibrates ? p.calibrate_hold_s + p.calibrate_wait_s : 0.0);
  const double t_neutral = t_arm + p.arm_hold_s;
  s.t_hover = t_neutral + kBackToNeutralS;
  s.t_step = s.t_hover + kSpoolS + o.settle_s;
  std::map<std::string, double> step = p.hover;
  const double base = p.channelValues(p.hover)[static_cast<std::size_t>(
      std::find(p.channels.begin(), p.channels.end(), r.axis) - p.channels.begin())];
  const double per_deg = r.axis == "roll" ? p.roll_us_per_deg : p.pitch_us_per_deg;
  step[r.axis] = base + o.step_deg * per_deg;
  if (step[r.axis] < kRcChannelMinUs || step[r.axis] > kRcChannelMaxUs)
    throw std::runtime_error(fmt::format("{}: a {}-degree {} step needs {:.0f} us on its stick; check deg-us in {}",
                                         runId(r), o.step_deg, r.axis, step[r.axis], p.file));
  s.rows = {row(p, 0.0, {})};
  if (calibrates)
    s.rows.insert(s.rows.end(), {row(p, p.boot_s, p.calibrate), row(p, p.boot_s + p.calibrate_hold_s, {})});
  s.rows.insert(s.rows.end(),
                {row(p, t_arm, p.arm), row(p, t_neutral, {}), row(p, s.t_hover, p.hover), row(p, s.t_step, step)});
  return s;
}

AirframeOptions peerRig(const PeerProfile& p, const SwapOptions& o, const RunSpec& r) {
  AirframeOptions a = rigOptions(o, r);
  a.gimbal.layout = p.layout == "plus" ? plant::Layout::kPlus : plant::Layout::kX;
  if (!p.spin.empty()) a.gimbal.common.spin = p.spin;
  a.esc_pins = p.esc_pins;
  a.imu_mount = p.imu_mount;
  return a;
}

double topPulse(const std::vector<AirSample>& log, double from_s, double to_s) {
  double top = 0;
  for (const AirSample& s : log)
    if (s.truth.t_s >= from_s && s.truth.t_s < to_s)
      for (int i = 0; i < s.motors; ++i) top = std::max(top, s.pulse_us[i]);
  return top;
}

void checkArmed(AirframeRig& rig, const PeerProfile& p, const RunSpec& r, double t_step) {
  const std::string& out = rig.board().output();
  const bool said = p.armed_text.empty() || out.find(p.armed_text) != std::string::npos;
  const double top = topPulse(rig.samples(), t_step - 0.25, t_step);
  if (said && top > kIdleUs) return;
  const std::string tail = out.size() > 400 ? out.substr(out.size() - 400) : out;
  throw std::runtime_error(fmt::format(
      "{}: the peer {} did not fly: {}; its largest pulse before the step {:.0f} us. Check arm, hover and "
      "channels in {} (and rc, esc-pins). Its UART0 ended with:\n{}",
      runId(r), p.name, said ? "it never ran its motors" : "it never printed '" + p.armed_text + "'", top,
      p.file, tail));
}

}  // namespace

RunResult flyPeerRun(const SwapOptions& o, const RunSpec& r, const std::string& csv_path) {
  if (!o.peer) throw std::logic_error("flyPeerRun without a peer profile");
  const PeerProfile& p = *o.peer;
  const auto wall0 = std::chrono::steady_clock::now();
  RunResult res;
  res.spec = r;
  if (!std::filesystem::exists(p.elf))
    throw std::runtime_error(fmt::format("{}: the peer's ELF {} does not exist; build it or fix elf", p.file, p.elf));
  AirframeRig rig(p.elf, peerRig(p, o, r));
  if (!p.eeprom.empty()) rig.board().setEeprom(hex::readIntelHexFile(p.eeprom, hal::kEepromBytes));
  RcOnBoard rc(rig.board(), parseRcSpec(p.rc.text, &p.esc_pins));
  const Sticks sticks = sticksOf(p, o, r);
  rc.play(sticks.rows);
  if (!p.uart_bytes.empty()) {
    rig.run(p.boot_s - rig.board().timeS());
    rig.board().sendText(p.uart_bytes);
  }
  rig.run(sticks.t_step - rig.board().timeS());
  checkArmed(rig, p, r, sticks.t_step);
  rig.run(o.window_s);
  res.integrator_mnm = std::numeric_limits<double>::quiet_NaN();  // not ours to read
  finishRun(res, rig, {sticks.t_step}, o.settle_s, o, csv_path, wall0);
  return res;
}

}  // namespace sim::swap

// `thrustcal sim liftoff`: read_run on the tethered quad frame.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "board/console_client.hpp"
#include "board/liftoff.hpp"
#include "board/serial_port.hpp"
#include "board/transfer.hpp"
#include "plant/quad_frame.hpp"
#include "plant/sensors.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/dynamics_session.hpp"
#include "sim/pty_bridge.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"

namespace sim {

QuadRig::QuadRig(const std::string& elf, const plant::QuadFrameParams& params,
                 const std::array<plant::ActuatorParams, 4>& motors, double sample_period_s)
    : owned(std::make_unique<Board>(elf)), board(*owned), quad(params, motors),
      vsense(plant::BatterySensorParams{}),
      sample_every(std::max<int>(1, static_cast<int>(std::lround(sample_period_s * 1000)))) {
  wire();
}

QuadRig::QuadRig(const FlashImages& images, const plant::QuadFrameParams& params,
                 const std::array<plant::ActuatorParams, 4>& motors, double sample_period_s)
    : owned(std::make_unique<Board>(images)), board(*owned), quad(params, motors),
      vsense(plant::BatterySensorParams{}),
      sample_every(std::max<int>(1, static_cast<int>(std::lround(sample_period_s * 1000)))) {
  wire();
}

QuadRig::QuadRig(Board& existing, const plant::QuadFrameParams& params,
                 const std::array<plant::ActuatorParams, 4>& motors, double sample_period_s)
    : board(existing), quad(params, motors), vsense(plant::BatterySensorParams{}),
      sample_every(std::max<int>(1, static_cast<int>(std::lround(sample_period_s * 1000)))) {
  wire();
}

void QuadRig::wire() {
  board.clearPlantWiring();
  last_t = board.timeS();
  board.addPulseListener(
      [this](int ch, double width_us, double t_s) { quad.setPulse(ch, width_us, t_s); });
  board.setAdcSource([this](int ch) { return ch == hal::kAdcBattery ? vsense.adcMillivolts() : 0.0; });
  vsense.settle(quad.power().restingVoltage_v());
  board.setTickHook([this](double t_s) {
    const double dt = t_s - last_t;
    last_t = t_s;
    quad.step(dt);
    vsense.step(dt, quad.busVoltage_v());
    if (recording && ++tick % sample_every == 0) {
      const plant::QuadState st = quad.state();
      LiftoffSample s{};
      s.t_s = t_s;
      s.thrust_g = st.thrust_g;
      for (int i = 0; i < 4; ++i) s.pwm_us[i] = board.escPulseUs(i);
      s.roll_deg = st.roll_deg;
      s.pitch_deg = st.pitch_deg;
      s.tilt_deg = st.tilt_deg;
      s.height_m = st.height_m;
      s.roll_moment_nm = st.roll_moment_nm;
      s.pitch_moment_nm = st.pitch_moment_nm;
      s.bus_v = st.bus_v;
      samples.push_back(s);
    }
  });
}

std::vector<std::string> bootReadRun(Console& con) {
  // banner, calibration report, 2 s arming, "armed", prompt
  return con.waitPrompt(10.0);
}

namespace {

// One flown lift-off: the rig (its samples), the times of the command, the hold and the end
// (simulated seconds, -1 when not seen), read_run's boot lines and the console's last lines.
struct Flight {
  std::unique_ptr<QuadRig> rig;
  double t_cmd = -1, t_hold = -1, t_done = -1;
  std::vector<std::string> boot;
  std::string tail;
};

// The line listener both paths share: the simulated times of "# hold" and "# liftoff done".
auto phaseTimes(Flight& f, const std::string& mode, const ProgressFn& progress) {
  return [&f, mode, progress](const std::string& line) {
    if (line.rfind("# hold", 0) == 0) f.t_hold = f.rig->board.timeS();
    if (line.rfind("# liftoff done", 0) == 0) f.t_done = f.rig->board.timeS();
    if (line.rfind("# t ", 0) == 0) progress(fmt::format("liftoff ({}): {}", mode, line.substr(2)));
  };
}

// read_run typed into straight through the simulated UART (simulated time only).
Flight flyInProcess(const LiftoffOptions& o, const plant::QuadFrameParams& qp,
                    const std::array<plant::ActuatorParams, 4>& motors,
                    const std::vector<uint8_t>& eeprom, const std::string& mode,
                    const ProgressFn& progress) {
  Flight f;
  f.rig = std::make_unique<QuadRig>(o.elf_path, qp, motors, o.sample_period_s);
  auto& rig = f.rig;
  rig->board.setEeprom(eeprom);
  Console con(rig->board, "rr> ");
  progress(fmt::format("liftoff ({}): read_run booting, seeds {} {} {} {}", mode, o.seeds[0],
                       o.seeds[1], o.seeds[2], o.seeds[3]));
  f.boot = bootReadRun(con);
  if (o.dyn) {
    const std::vector<std::string> reply = con.command("dyn on", 2.0);
    if (reply.empty() || reply[0].rfind("dyn on:", 0) != 0)
      throw std::runtime_error("read_run refused `dyn on`: " + (reply.empty() ? con.tail() : reply[0]));
  }
  con.onLine(phaseTimes(f, mode, progress));
  rig->recording = true;
  f.t_cmd = rig->board.timeS();
  con.send(fmt::format("liftoff {} {} {}", static_cast<int>(std::lround(o.force_g)), o.ramp_ms,
                       o.hold_ms));
  // The lift-off stops when the link goes quiet for 500 ms: an empty line every 200 ms keeps it.
  con.setKeepAlive(0.2);
  const auto end = con.expect("^(# liftoff (done|aborted|stopped).*|error: .*)$",
                              (o.ramp_ms + o.hold_ms) / 1000.0 + 5.0);
  con.setKeepAlive(0);
  if (end[0].rfind("error:", 0) == 0)
    throw std::runtime_error(fmt::format("read_run refused the lift-off: {}", end[0]));
  con.waitPrompt(1.0);
  rig->board.runFor(0.5);  // spin-down
  rig->recording = false;
  con.clearLineListeners();
  f.tail = con.tail();
  return f;
}

// read_run as a user's cable reaches it: the board boots from the bootloader behind a pty and
// `thrustcal board liftoff`'s client code flies it (stream on, liftoff, stream off).
Flight flyOverPty(const LiftoffOptions& o, const plant::QuadFrameParams& qp,
                  const std::array<plant::ActuatorParams, 4>& motors,
                  const std::vector<uint8_t>& eeprom, const std::string& mode,
                  const ProgressFn& progress) {
  Flight f;
  f.rig = std::make_unique<QuadRig>(FlashImages{o.bootloader_hex, o.elf_path}, qp, motors,
                                    o.sample_period_s);
  auto& rig = f.rig;
  rig->board.setEeprom(eeprom);
  // The phase lines, timed in the simulation's thread as they leave the board.
  std::string line;
  auto on_phase = phaseTimes(f, mode, progress);
  rig->board.addOutputListener([&line, on_phase](uint8_t byte) {
    if (byte == '\n') {
      on_phase(line);
      line.clear();
    } else if (byte != '\r' && line.size() < 200) {
      line.push_back(static_cast<char>(byte));
    }
  });
  PtyOptions po;
  po.reset_on_open = true;
  po.real_time_while = [&rig] { return anyEscAbove(rig->board); };  // the keep-alives' clock
  PtyBridge link(rig->board, po);
  link.start(Pacing{1.0, 0.0});
  progress(fmt::format("liftoff ({}): board on {}: reset, bootloader, read_run, seeds {} {} {} {}",
                       mode, link.path(), o.seeds[0], o.seeds[1], o.seeds[2], o.seeds[3]));
  board::LiftoffOptions lo;
  lo.force_g = static_cast<int>(std::lround(o.force_g));
  lo.ramp_ms = o.ramp_ms;
  lo.hold_ms = o.hold_ms;
  try {
    board::SerialPort port(link.path());
    board::ConsoleClient con(port);
    f.boot = con.waitForBoot(board::kBootTimeoutS);
    board::flyLiftoff(con, lo, [&](const std::string&) {
      link.paused([&] {
        rig->recording = true;
        f.t_cmd = rig->board.timeS();
      });
      return true;
    });
    f.tail = con.tail();
  } catch (...) {
    try {
      link.stop();  // a crashed firmware says more than the client's time-out
    } catch (const std::exception& e) {
      throw std::runtime_error(fmt::format("liftoff ({}): {}", mode, e.what()));
    }
    throw;
  }
  link.paused([&] {
    rig->board.runFor(0.5);  // spin-down
    rig->recording = false;
  });
  link.stop();  // the board is not run again: the listener above refers to this frame
  return f;
}

// The EEPROM read_run boots with: the image as given (calibrated), or the reference slot's
// record copied into all four slots (uncalibrated: one generic curve for every motor).
std::vector<uint8_t> eepromToFly(const LiftoffOptions& o) {
  std::vector<uint8_t> eeprom = o.eeprom;
  if (eeprom.size() != kEepromBytes)
    throw std::invalid_argument(fmt::format("liftoff needs a {}-byte EEPROM image, got {} bytes",
                                            kEepromBytes, eeprom.size()));
  if (!o.uncalibrated) return eeprom;
  tc::MotorCalibration ref;
  tc::ModelV2 ref_v2;
  const std::string status = decodeSlot(eeprom, o.reference_slot, ref);
  if (status != "ok" && decodeSlotV2(eeprom, o.reference_slot, ref_v2) != "ok")
    throw std::invalid_argument(fmt::format(
        "uncalibrated mode copies slot {}'s record to all four, but it is '{}'; calibrate it "
        "first (thrustcal sim gather)",
        o.reference_slot, status));
  for (int s = 0; s < 4; ++s) copySlot(eeprom, o.reference_slot, s);
  return eeprom;
}

// read_run's start-up report: the calibration lines, and which model each slot flies.
void readBootReport(const std::vector<std::string>& boot, LiftoffResult& r) {
  for (const auto& line : boot) {
    if (line.rfind("motor ", 0) == 0 || line.rfind("calibrated motors", 0) == 0)
      r.calibration_report.push_back(line);
    int slot = -1;  // "motor K: ok, ... model v1 (...)" / "motor K: ok, model v2 (...)"
    if (std::sscanf(line.c_str(), "motor %d: ok", &slot) == 1 && slot >= 0 && slot < 4)
      for (const char* model : {"v1", "v2"})
        if (line.find(std::string("model ") + model) != std::string::npos) r.models[slot] = model;
  }
}

// The hold phase from..to (simulated s): mean thrust and pulse per motor, their spread and
// error against the command, tilt, moments and bus voltage; the largest tilt of the whole run.
void summarizeHold(const LiftoffOptions& o, const std::vector<LiftoffSample>& samples, double from,
                   double to, LiftoffResult& r) {
  int n = 0;
  double tilt_sum = 0, roll_m = 0, pitch_m = 0, bus = 0;
  for (const auto& s : samples) {
    r.max_tilt_deg = std::max(r.max_tilt_deg, s.tilt_deg);
    if (s.t_s < from || s.t_s > to) continue;
    for (int i = 0; i < 4; ++i) {
      r.hold_thrust_g[i] += s.thrust_g[i];
      r.hold_pwm_us[i] += s.pwm_us[i];
    }
    tilt_sum += s.tilt_deg;
    roll_m += s.roll_moment_nm;
    pitch_m += s.pitch_moment_nm;
    bus += s.bus_v;
    ++n;
  }
  if (n == 0)
    throw std::runtime_error(fmt::format(
        "the hold phase ({:.2f}..{:.2f} s) has no samples: hold longer than --settle", from, to));
  double mean = 0, lo = 1e9, hi = -1e9, err2 = 0;
  for (int i = 0; i < 4; ++i) {
    r.hold_thrust_g[i] /= n;
    r.hold_pwm_us[i] /= n;
    mean += r.hold_thrust_g[i] / 4;
    lo = std::min(lo, r.hold_thrust_g[i]);
    hi = std::max(hi, r.hold_thrust_g[i]);
    const double e = (r.hold_thrust_g[i] - o.force_g) / o.force_g * 100.0;
    err2 += e * e / 4;
  }
  r.thrust_spread_pct = mean > 0 ? (hi - lo) / mean * 100.0 : 0;
  r.force_error_rms_pct = std::sqrt(err2);
  r.hold_tilt_deg = tilt_sum / n;
  r.hold_roll_moment_nm = roll_m / n;
  r.hold_pitch_moment_nm = pitch_m / n;
  r.hold_bus_v = bus / n;
}

// The ramp (before `t_hold`, once the four thrusts' mean passes 20 % of the force): the largest
// spread of the four, relative to their mean.
double rampSpreadPct(const LiftoffOptions& o, const std::vector<LiftoffSample>& samples, double t_hold) {
  double worst = 0;
  for (const auto& s : samples) {
    if (s.t_s >= t_hold) break;
    const double m = (s.thrust_g[0] + s.thrust_g[1] + s.thrust_g[2] + s.thrust_g[3]) / 4;
    if (m < 0.2 * o.force_g) continue;
    const auto [min_it, max_it] = std::minmax_element(s.thrust_g.begin(), s.thrust_g.end());
    worst = std::max(worst, (*max_it - *min_it) / m * 100.0);
  }
  return worst;
}

// The 10 ms time series, t_s from the command.
void writeLiftoffCsv(const LiftoffOptions& o, const LiftoffResult& r, double t_cmd, double t_hold) {
  std::ofstream out(o.csv_path, std::ios::trunc);
  if (!out)
    throw std::runtime_error(fmt::format("{}: cannot write the time series; check the path",
                                         o.csv_path));
  out << fmt::format(
      "# thrustcal sim liftoff ({}): read_run, liftoff {} g ramp {} ms hold {} ms; t_s from "
      "the command; hold from {:.3f} s\n",
      r.mode, o.force_g, o.ramp_ms, o.hold_ms, t_hold - t_cmd);
  out << "t_s,thrust0_g,thrust1_g,thrust2_g,thrust3_g,pwm0_us,pwm1_us,pwm2_us,pwm3_us,roll_deg,"
         "pitch_deg,tilt_deg,height_m,roll_moment_nm,pitch_moment_nm,bus_v\n";
  for (const auto& s : r.samples) {
    out << fmt::format("{:.3f}", s.t_s - t_cmd);
    for (double v : s.thrust_g) out << fmt::format(",{:.2f}", v);
    for (double v : s.pwm_us) out << fmt::format(",{:.1f}", v);
    out << fmt::format(",{:.3f},{:.3f},{:.3f},{:.4f},{:.4f},{:.4f},{:.3f}\n", s.roll_deg,
                       s.pitch_deg, s.tilt_deg, s.height_m, s.roll_moment_nm, s.pitch_moment_nm,
                       s.bus_v);
  }
}

}  // namespace

LiftoffResult runLiftoff(const LiftoffOptions& o) {
  const ProgressFn progress = o.progress ? o.progress : ProgressFn(stderrProgress);
  LiftoffResult r;
  r.mode = !o.label.empty() ? o.label : o.uncalibrated ? "uncalibrated" : "calibrated";
  r.force_g = o.force_g;
  if (o.dyn && o.link == GatherLink::kPty)
    throw std::invalid_argument("liftoff with dyn on runs in process only (--via in-process)");
  std::vector<uint8_t> eeprom = eepromToFly(o);
  if (o.dyn)  // each v2 record with its motor's dynamics: the plant's own (what gather_store's dyn measures);
    for (int i = 0; i < 4; ++i)  // a thesis record has none and flies unshaped
      storePlantDynamics(eeprom, i, motorForSeed(o.preset, o.seeds[i], o.variation));
  plant::QuadFrameParams qp;
  qp.power = plant::BatteryParams::lipo3s(o.lipo_soc);
  std::array<plant::ActuatorParams, 4> motors;
  for (int i = 0; i < 4; ++i) motors[i] = motorForSeed(o.preset, o.seeds[i], o.variation);
  const auto session0 = std::chrono::steady_clock::now();
  r.link = o.link;
  Flight f = o.link == GatherLink::kPty ? flyOverPty(o, qp, motors, eeprom, r.mode, progress)
                                        : flyInProcess(o, qp, motors, eeprom, r.mode, progress);
  r.session_wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - session0).count();
  auto& rig = f.rig;
  const double t_cmd = f.t_cmd, t_done = f.t_done;
  double t_hold = f.t_hold;
  readBootReport(f.boot, r);
  if (t_done < 0)
    throw std::runtime_error(fmt::format("read_run did not finish the lift-off; last lines:\n{}",
                                         f.tail));
  if (t_hold < 0) t_hold = t_cmd + o.ramp_ms / 1000.0;
  summarizeHold(o, rig->samples, t_hold + o.settle_s, t_done - 0.02, r);
  r.ramp_spread_pct = rampSpreadPct(o, rig->samples, t_hold);
  r.samples = std::move(rig->samples);
  r.simulated_s = rig->board.simulatedSeconds();
  r.wall_s = rig->board.wallSeconds();
  r.realtime_factor = rig->board.realtimeFactor();
  if (!o.csv_path.empty()) {
    r.csv_path = o.csv_path;
    writeLiftoffCsv(o, r, t_cmd, t_hold);
  }
  progress(fmt::format(
      "liftoff ({}): hold thrust {:.1f} {:.1f} {:.1f} {:.1f} g (command {:.0f} g): spread "
      "{:.2f} %, rms error {:.2f} %, tilt {:.2f} deg",
      r.mode, r.hold_thrust_g[0], r.hold_thrust_g[1], r.hold_thrust_g[2], r.hold_thrust_g[3],
      o.force_g, r.thrust_spread_pct, r.force_error_rms_pct, r.hold_tilt_deg));
  return r;
}

nlohmann::json LiftoffResult::toJson() const {
  return {{"force_g", force_g},
          {"models", models},
          {"hold_thrust_g", hold_thrust_g},
          {"hold_pwm_us", hold_pwm_us},
          {"thrust_spread_pct", thrust_spread_pct},
          {"ramp_spread_pct", ramp_spread_pct},
          {"force_error_rms_pct", force_error_rms_pct},
          {"hold_tilt_deg", hold_tilt_deg},
          {"max_tilt_deg", max_tilt_deg},
          {"hold_roll_moment_nm", hold_roll_moment_nm},
          {"hold_pitch_moment_nm", hold_pitch_moment_nm},
          {"hold_bus_v", hold_bus_v},
          {"calibration_report", calibration_report},
          {"csv", csv_path},
          {"simulated_s", simulated_s},
          {"wall_s", wall_s},
          {"session_wall_s", session_wall_s},
          {"link", gatherLinkName(link)},
          {"realtime_factor", realtime_factor}};
}

}  // namespace sim

// gather_store's dyn session on the virtual bench (sim/dynamics_session.hpp).
#include "sim/dynamics_session.hpp"
#include "sim/watchdog_gaps.hpp"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <stdexcept>

#include "plant/dynamics_record.hpp"
#include "plant/fidelity.hpp"
#include "sim/console.hpp"
#include "sim/rigs.hpp"
#include "thrustcal/board_settings.hpp"
#include "thrustcal/eeprom_image.hpp"
#include "thrustcal/record_v2.hpp"

namespace sim {

namespace {

constexpr double kPlantStepS = 0.00025;

// The board settings an EEPROM image holds (defaults where it holds none valid).
tc::DecodeStatus readImageSettings(const std::vector<uint8_t>& eeprom, tc::BoardSettings& settings) {
  const tc::EepromImage::Use use(eeprom);
  return tc::readSettings<tc::EepromImage>(settings).status;
}

// Slot's v2 record in the image; false when there is none valid.
bool readSlotModel(const std::vector<uint8_t>& eeprom, int slot, tc::ModelV2& model) {
  tc::BoardSettings settings;
  readImageSettings(eeprom, settings);
  const tc::EepromImage::Use use(eeprom);
  return tc::readModelV2<tc::EepromImage>(static_cast<uint8_t>(slot), model, settings.recordLimits()).status ==
         tc::DecodeStatus::kOk;
}

std::vector<std::string> must(Console& con, const std::string& line, double budget_s) {
  auto lines = con.command(line, budget_s);
  for (const auto& l : lines)
    if (l.rfind("error:", 0) == 0)
      throw std::runtime_error(fmt::format("gather_store refused \"{}\": {}\nlast lines:\n{}", line, l, con.tail()));
  return lines;
}

// "# step up 1302 -> 1323 us at t_s 2.1234 (the ESC's edge); bus 11.920 V"
bool parseStep(const std::string& l, DynStep& s) {
  char dir[8] = {};
  int from = 0, to = 0;
  double t = 0, v = 0;
  if (std::sscanf(l.c_str(), "# step %7s %d -> %d us at t_s %lf (the ESC's edge); bus %lf V", dir, &from, &to, &t,
                  &v) != 5)
    return false;
  s = DynStep();
  s.dir = std::string(dir) == "up" ? 1 : -1;
  s.from_us = from;
  s.to_us = to;
  s.bus_v = v;
  return true;
}

// "# fit up 1302 -> 1323 us at 160.2 g: tau 79.1 ms, ..." or "...: not usable: ..."
void parseFit(const std::string& l, DynStep& s) {
  double f = 0, tau_ms = 0;
  const std::size_t at = l.find(" us at ");
  if (at == std::string::npos) return;
  if (std::sscanf(l.c_str() + at, " us at %lf g: tau %lf ms", &f, &tau_ms) == 2) {
    s.ok = true;
    s.force_g = f;
    s.tau_s = tau_ms / 1000.0;
  }
}

}  // namespace

tc::MotorDynamics storedDynamics(const std::vector<uint8_t>& eeprom, int slot) {
  tc::ModelV2 model;
  return readSlotModel(eeprom, slot, model) ? model.dynamics : tc::MotorDynamics();
}

bool storePlantDynamics(std::vector<uint8_t>& eeprom, int slot, const plant::ActuatorParams& motor) {
  tc::ModelV2 model;
  if (!readSlotModel(eeprom, slot, model)) return false;
  model.dynamics = plant::recordDynamics(motor);
  const tc::EepromImage::Use use(eeprom);
  if (tc::writeModelV2<tc::EepromImage>(static_cast<uint8_t>(slot), model).status != tc::WriteV2Status::kWritten)
    throw std::runtime_error(fmt::format("slot {}'s record with the motor's dynamics was not written", slot));
  return true;
}

plant::BenchParams dynBenchParams(const plant::ActuatorParams& motor, double headroom_g, uint64_t noise_seed) {
  plant::BenchParams p = plant::BenchParams::thesis();
  p.actuator = motor;
  p.load_cell.seed = noise_seed * 1000003ULL + 17;
  p.battery_sensor.seed = noise_seed * 1000003ULL + 29;
  // The output clips at 0 V with plate + mount + headroom_g pressing down.
  p.load_cell.offset_mv = p.load_cell.millivoltsPerGram() * (p.load_cell.plate_g + motor.mountWeight_g() + headroom_g);
  return p;
}

DynSessionResult runDynSession(const DynSessionOptions& o) {  // long: the session as typed, step by step
  const ProgressFn progress = o.progress ? o.progress : stderrProgress;
  const plant::BenchParams params = dynBenchParams(o.motor, o.headroom_g, o.noise_seed);
  auto rig = std::make_unique<BenchRig>(o.elf_path, params, o.slot);
  if (!o.eeprom.empty()) rig->board.setEeprom(o.eeprom);
  // The plant in steps of kPlantStepS rather than the rig's 1 ms: an ESC edge reaches the motor,
  // and the motor's force the ADC, within that of when they happen (a step log resolves
  // milliseconds; the analog bench has no such grid).
  BenchRig* const rp = rig.get();
  auto tick = [rp](double t_s, std::ofstream* truth) {
    rp->bench.step(t_s - rp->last_t);
    rp->last_t = t_s;
    if (truth && *truth)
      *truth << fmt::format("{:.5f},{:.1f},{:.1f},{:.3f},{:.4f}\n", t_s, rp->bench.actuator().lastPulse_us(),
                            rp->bench.actuator().rpm(), rp->bench.actuator().thrust_g(), rp->bench.busVoltage_v());
  };
  rig->board.setTickHook([tick](double t_s) { tick(t_s, nullptr); }, secondsToCycles(kPlantStepS));
  Console con(rig->board, "gs> ");
  con.waitPrompt(10.0);
  std::unique_ptr<KickGapMeter> kicks;
  if (o.watch_kicks) kicks = std::make_unique<KickGapMeter>(rig->board, o.elf_path);
  must(con, fmt::format("motor {}", o.slot), 5);
  must(con, fmt::format("plate {}", static_cast<int>(std::lround(params.load_cell.plate_g))), 5);
  must(con, fmt::format("cal {}", static_cast<int>(std::lround(o.motor.mountWeight_g()))), 15);
  std::ofstream log;
  if (!o.log_path.empty()) {
    log.open(o.log_path, std::ios::trunc);
    if (!log) throw std::runtime_error(o.log_path + ": cannot write the step log; check the folder");
  }
  DynSessionResult r;
  tc::BoardSettings settings;
  if (o.eeprom.empty() || readImageSettings(o.eeprom, settings) != tc::DecodeStatus::kOk ||
      !settings.bench.isPresent()) {
    progress(fmt::format("slot {}: dyn cell, a {:.0f} g weight lifted off the plate", o.slot, o.cell_weight_g));
    rig->bench.placeWeight_g(o.cell_weight_g);
    rig->board.runFor(1.0);
    con.send("dyn cell");
    con.expectText("now lift the weight off", 10.0);
    rig->board.runFor(0.3);
    rig->bench.removeWeights();
    for (const auto& l : con.waitPrompt(30.0)) {
      if (log) log << l << "\n";
      if (l.rfind("error:", 0) == 0) throw std::runtime_error("dyn cell: " + l + "\n" + con.tail());
    }
  }
  if (o.calibrate) {
    must(con, fmt::format("step {}", o.sweep_step_us), 5);
    must(con, fmt::format("settle {}", o.sweep_settle_ms), 5);
    progress(fmt::format("slot {}: calibration sweep ({} us, {} ms) and store v2", o.slot, o.sweep_step_us,
                         o.sweep_settle_ms));
    must(con, "sweep", 120);
    for (const auto& l : must(con, "store v2", 10)) progress(fmt::format("slot {}: {}", o.slot, l));
    rig->board.runUntil([&] { return rig->bench.actuator().rpm() < 20.0; }, secondsToCycles(30.0));
    rig->board.runFor(0.5);
    must(con, "tare", 15);
  }
  progress(fmt::format("slot {}: dyn ({})", o.slot, o.motor.name));
  DynStep step;
  con.onLine([&](const std::string& l) {
    if (log) log << l << "\n";
    if (parseStep(l, step)) return;
    if (l.rfind("# fit ", 0) == 0 && l.rfind("# fit cell", 0) != 0) {
      parseFit(l, step);
      if (step.ok)
        step.truth_s = plant::stepTimeConstant_s(o.motor, step.bus_v, step.from_us, step.to_us);
      r.steps.push_back(step);
      progress(l.substr(2));
    } else if (!l.empty() && l[0] != '#' && !std::isdigit(static_cast<unsigned char>(l[0])) && l.rfind("gs>", 0) != 0 &&
               l.rfind("t_s,", 0) != 0) {
      r.summary.push_back(l);
    }
  });
  std::ofstream truth;
  if (!o.truth_path.empty()) {  // the plant at every step: what the motor really did
    truth.open(o.truth_path, std::ios::trunc);
    truth << "t_s,pulse_us,rpm,thrust_g,bus_v\n";
    rig->board.setTickHook([tick, &truth](double t_s) { tick(t_s, &truth); }, secondsToCycles(kPlantStepS));
  }
  const double t0 = rig->board.simulatedSeconds();
  const auto lines = con.command("dyn", 90.0);
  r.session_s = rig->board.simulatedSeconds() - t0;
  con.clearLineListeners();
  for (const auto& l : lines)
    if (l.rfind("error:", 0) == 0) throw std::runtime_error("dyn: " + l + "\n" + con.tail());
  r.eeprom = rig->board.eeprom();
  readImageSettings(r.eeprom, settings);
  r.bench = settings.bench;
  r.dynamics = storedDynamics(r.eeprom, o.slot);
  r.simulated_s = rig->board.simulatedSeconds();
  r.wall_s = rig->board.wallSeconds();
  if (kicks) {
    r.longest_kick_gap_ms = kicks->longestMs();
    r.kick_gap_where = kicks->longestFrom() + " -> " + kicks->longestTo();
  }
  return r;
}

}  // namespace sim

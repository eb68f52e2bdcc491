// `thrustcal sim gather`: gather_store on the simulated thesis bench.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <sstream>

#include "board/calibrate.hpp"
#include "board/console_client.hpp"
#include "board/serial_port.hpp"
#include "board/transfer.hpp"
#include "plant/bench.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/pty_bridge.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"
#include "thrustcal/model_v2.hpp"
#include "gather_checks.hpp"

namespace sim {

const char* gatherModelName(GatherModel model) {
  return model == GatherModel::kModelV2 ? "v2" : "v1";
}

const char* gatherLinkName(GatherLink link) {
  return link == GatherLink::kPty ? "pty" : "in-process";
}

BenchRig::BenchRig(const std::string& elf, const plant::BenchParams& params, int esc_slot)
    : owned(std::make_unique<Board>(elf)), board(*owned), bench(params), slot(esc_slot) {
  wire();
}

BenchRig::BenchRig(const FlashImages& images, const plant::BenchParams& params, int esc_slot)
    : owned(std::make_unique<Board>(images)), board(*owned), bench(params), slot(esc_slot) {
  wire();
}

BenchRig::BenchRig(Board& existing, const plant::BenchParams& params, int esc_slot)
    : board(existing), bench(params), slot(esc_slot) {
  wire();
}

void BenchRig::wire() {
  board.clearPlantWiring();
  last_t = board.timeS();
  bench.loadCell().settle(bench.downForce_g());
  board.addPulseListener([this](int ch, double width_us, double t_s) {
    if (ch == slot) bench.setPulse(width_us, t_s);
  });
  board.setAdcSource([this](int ch) { return ch <= 1 ? bench.adcMillivolts(ch) : 0.0; });
  board.setTickHook([this](double t_s) {
    bench.step(t_s - last_t);
    last_t = t_s;
  });
}

namespace {

// Sends a command and fails loudly when the firmware answers with an error line.
std::vector<std::string> mustCommand(Console& con, const std::string& line, double budget_s = 10) {
  auto lines = con.command(line, budget_s);
  for (const auto& l : lines)
    if (l.rfind("error:", 0) == 0)
      throw std::runtime_error(fmt::format("gather_store rejected \"{}\": {}\nlast lines:\n{}",
                                           line, l, con.tail()));
  return lines;
}

std::string fmtCsvNumber(double v, int decimals) { return fmt::format("{:.{}f}", v, decimals); }

struct SweepCapture {
  std::ofstream csv;
  int rows = 0;
  bool active = false;
};

CurveCheck runSweep(BenchRig& rig, Console& con, const GatherOptions& o, int slot, int curve_no,
                    const ProgressFn& progress, plant::Bench& truth_out) {
  CurveCheck check;
  SweepCapture cap;
  if (!o.log_dir.empty()) {
    check.csv_path =
        (std::filesystem::path(o.log_dir) / fmt::format("gather_slot{}_curve{}.csv", slot, curve_no))
            .string();
    cap.csv.open(check.csv_path, std::ios::trunc);
    if (!cap.csv)
      throw std::runtime_error(fmt::format("{}: cannot write the sweep log; check --log-dir",
                                           check.csv_path));
    cap.csv << fmt::format(
        "# thrustcal sim gather: slot {} curve {}, streamed by gather_store (first six columns);\n"
        "# current_a, rpm, temp_c: instruments on the plant at the moment the row was printed\n",
        slot, curve_no);
  }
  cap.active = true;
  struct ListenerGuard {
    Console& con;
    ~ListenerGuard() { con.clearLineListeners(); }
  } guard{con};
  con.onLine([&cap, &rig, &progress](const std::string& line) {
    if (!cap.active) return;
    if (line.rfind("# ", 0) == 0) {
      if (progress) progress(line.substr(2));
      if (cap.csv) cap.csv << line << "\n";
    } else if (line.rfind("pwm_us,", 0) == 0) {
      if (cap.csv) cap.csv << line << ",current_a,rpm,temp_c\n";
    } else if (!line.empty() && std::isdigit(static_cast<unsigned char>(line[0]))) {
      ++cap.rows;
      if (cap.csv) {
        const auto& a = rig.bench.actuator();
        cap.csv << line << "," << fmtCsvNumber(rig.bench.busCurrent_a(), 3) << ","
                << fmtCsvNumber(a.rpm(), 0) << "," << fmtCsvNumber(a.windingTemp_c(), 2) << "\n";
      }
    }
  });
  truth_out = rig.bench;  // the truth: this bench as the sweep starts
  const int steps = (o.pwm_max_us - o.pwm_min_us) / o.step_us + 1;
  const double budget_s = steps * (o.settle_ms / 1000.0 + 0.25) + 15.0;
  const double sim0 = rig.board.simulatedSeconds(), wall0 = rig.board.wallSeconds();
  auto lines = con.command("sweep", budget_s);
  cap.active = false;
  check.sweep_simulated_s = rig.board.simulatedSeconds() - sim0;
  check.sweep_wall_s = rig.board.wallSeconds() - wall0;
  check.samples = cap.rows;
  bool done = false;
  for (const auto& l : lines) {
    if (l.rfind("error:", 0) == 0)
      throw std::runtime_error(fmt::format("sweep on slot {} refused: {}", slot, l));
    if (l.rfind("# done:", 0) == 0) done = true;
    std::sscanf(l.c_str(), "# max force %lf g", &check.sweep_max_g);
  }
  if (!done || check.sweep_max_g <= 0)
    throw std::runtime_error(fmt::format("sweep on slot {} did not {}; last lines:\n{}", slot,
                                         done ? "report its max force" : "complete", con.tail()));
  return check;
}

// The second sweep's power: a bench supply or the pack drained.
void swapPower(BenchRig& rig, const GatherOptions& o) {
  if (o.second == SecondCurveSource::kBenchSupply)
    rig.bench.power() = plant::PowerSource(plant::BatteryParams::benchSupply(o.supply_v));
  else
    rig.bench.power().setSoc(o.drained_soc);
}

// Tare only once the propeller stands still (it coasts for seconds on its own drag), as a
// person at the bench would wait.
void waitForStandstill(BenchRig& rig, int slot) {
  if (!rig.board.runUntil([&] { return rig.bench.actuator().rpm() < 20.0; }, secondsToCycles(30.0)))
    throw std::runtime_error(fmt::format("slot {}: the propeller still turns 30 s after the "
                                         "sweep ({:.0f} rpm)",
                                         slot, rig.bench.actuator().rpm()));
  rig.board.runFor(0.5);
}

// gather_store driven by typing straight into the simulated UART (simulated time only: the
// same seed gives the same bytes).
void gatherInProcess(const GatherOptions& o, const plant::BenchParams& params,
                     const ProgressFn& progress, GatherMotorResult& mr,
                     std::optional<plant::Bench>& truth1, std::optional<plant::Bench>& truth2,
                     std::vector<uint8_t>& eeprom, double& sim_s, double& wall_s) {
  auto rig = std::make_unique<BenchRig>(o.elf_path, params, mr.slot);
  rig->board.setEeprom(eeprom);
  Console con(rig->board, "gs> ");
  progress(fmt::format("slot {}: motor seed {} ({}), gather_store booting", mr.slot, mr.seed,
                       o.preset));
  con.waitPrompt(10.0);
  mustCommand(con, fmt::format("motor {}", mr.slot));
  mustCommand(con, fmt::format("plate {}", static_cast<int>(std::lround(params.load_cell.plate_g))));
  mustCommand(con, fmt::format("range {} {}", o.pwm_min_us, o.pwm_max_us));
  mustCommand(con, fmt::format("step {}", o.step_us));
  mustCommand(con, fmt::format("settle {}", o.settle_ms));
  if (o.settle_auto) mustCommand(con, "settle auto");
  auto cal = mustCommand(con, fmt::format("cal {}", static_cast<int>(mr.mount_weight_g)), 15);
  progress(fmt::format("slot {}: cal {} g: {}", mr.slot, mr.mount_weight_g,
                       cal.empty() ? "" : cal.back()));
  // v1: store 1 / store 2; v2: store v2 after each sweep (fit, then refine).
  auto store = [&](int curve_no) {
    const std::string cmd = o.model == GatherModel::kModelV2 ? std::string("store v2")
                                                             : fmt::format("store {}", curve_no);
    const auto lines = mustCommand(con, cmd);
    mr.store.insert(mr.store.end(), lines.begin(), lines.end());
  };
  progress(fmt::format("slot {}: curve 1 sweep on the LiPo ({:.2f} V resting)", mr.slot,
                       rig->bench.restingVoltage_v()));
  truth1 = rig->bench;
  mr.curve1 = runSweep(*rig, con, o, mr.slot, 1, progress, *truth1);
  store(1);
  swapPower(*rig, o);
  waitForStandstill(*rig, mr.slot);
  mustCommand(con, "tare", 15);
  progress(fmt::format("slot {}: curve 2 sweep on the {}", mr.slot, mr.second_source));
  truth2 = rig->bench;
  mr.curve2 = runSweep(*rig, con, o, mr.slot, 2, progress, *truth2);
  store(2);
  mr.show = mustCommand(con, "show");
  eeprom = rig->board.eeprom();
  sim_s = rig->board.simulatedSeconds();
  wall_s = rig->board.wallSeconds();
}

// The plant's instruments at the moment each CSV row of a sweep left the board (a data logger
// beside the bench listening to UART0 in the simulation's thread; the rows themselves reach
// the scenario through the pty).
struct InstrumentTap {
  bool active = false;
  std::string line;
  std::vector<std::pair<std::string, std::string>> rows;  // row as printed, ",current,rpm,temp"
};

// The person at the simulated bench: says yes, changes the supply between the sweeps and waits
// for the propeller to stop, snapshots the truth as each sweep starts. Touches the plant only
// while the bridge holds the simulation still.
class BenchOperator : public board::Operator {
 public:
  BenchOperator(PtyBridge& link, BenchRig& rig, InstrumentTap& tap, const GatherOptions& o,
                const ProgressFn& progress, GatherMotorResult& mr,
                std::array<std::optional<plant::Bench>, 2>& truth)
      : link_(link), rig_(rig), tap_(tap), o_(o), progress_(progress), mr_(mr), truth_(truth) {}
  bool confirmSpin(const std::string&) override { return true; }
  void prepareSecondSweep(const std::string&) override {
    link_.paused([&] {
      swapPower(rig_, o_);
      waitForStandstill(rig_, mr_.slot);
    });
  }
  void sweepStarting(int sweep) override {
    link_.paused([&] {
      truth_[sweep - 1] = rig_.bench;
      sim0_ = rig_.board.simulatedSeconds();
      wall0_ = rig_.board.wallSeconds();
      tap_.rows.clear();
      tap_.active = true;
    });
    progress_(sweep == 1 ? fmt::format("slot {}: curve 1 sweep on the LiPo ({:.2f} V resting)",
                                       mr_.slot, truth_[0]->restingVoltage_v())
                         : fmt::format("slot {}: curve 2 sweep on the {}", mr_.slot,
                                       mr_.second_source));
  }
  void sweepEnded(int sweep, const board::SweepLog&) override {
    link_.paused([&] {
      tap_.active = false;
      CurveCheck& c = sweep == 1 ? mr_.curve1 : mr_.curve2;
      c.sweep_simulated_s = rig_.board.simulatedSeconds() - sim0_;
      c.sweep_wall_s = rig_.board.wallSeconds() - wall0_;
      rows_[sweep - 1] = tap_.rows;
    });
  }
  void note(const std::string& line) override {
    if (line.rfind("# ", 0) == 0) progress_(line.substr(2));
  }
  const std::vector<std::pair<std::string, std::string>>& rows(int sweep) const {
    return rows_[sweep - 1];
  }

 private:
  PtyBridge& link_;
  BenchRig& rig_;
  InstrumentTap& tap_;
  const GatherOptions& o_;
  const ProgressFn& progress_;
  GatherMotorResult& mr_;
  std::array<std::optional<plant::Bench>, 2>& truth_;
  double sim0_ = 0, wall0_ = 0;
  std::array<std::vector<std::pair<std::string, std::string>>, 2> rows_;
};

// The sweep as the client captured it, with the plant's instruments, in the project's CSV.
void writeSweepCsv(const std::string& path, const board::SweepLog& log,
                   const std::vector<std::pair<std::string, std::string>>& instruments, int slot,
                   int curve_no) {
  if (instruments.size() != log.rows.size())
    throw std::runtime_error(fmt::format(
        "slot {} sweep {}: the board printed {} rows, the pty delivered {}", slot, curve_no,
        instruments.size(), log.rows.size()));
  std::ofstream out(path, std::ios::trunc);
  if (!out)
    throw std::runtime_error(fmt::format("{}: cannot write the sweep log; check --log-dir", path));
  out << fmt::format(
      "# thrustcal sim gather: slot {} curve {}, streamed by gather_store over the pty (first six "
      "columns);\n# current_a, rpm, temp_c: instruments on the plant at the moment the row was "
      "printed\n",
      slot, curve_no);
  std::size_t row = 0;
  for (const auto& l : log.lines) {
    if (l.rfind("# ", 0) == 0) {
      out << l << "\n";
    } else if (l.rfind("pwm_us,", 0) == 0) {
      out << l << ",current_a,rpm,temp_c\n";
    } else if (row < log.rows.size() && l == log.rows[row]) {
      if (instruments[row].first != l)
        throw std::runtime_error(fmt::format(
            "slot {} sweep {} row {}: the board printed \"{}\", the pty delivered \"{}\"", slot,
            curve_no, row + 1, instruments[row].first, l));
      out << l << instruments[row].second << "\n";
      ++row;
    }
  }
}

// Records the plant's instruments (bus current, rpm, winding temperature) at the moment the
// board prints each CSV row of a sweep, into `tap`.
void tapInstruments(BenchRig& rig, InstrumentTap& tap) {
  rig.board.addOutputListener([&tap, r = &rig](uint8_t byte) {
    if (byte != '\n') {
      if (byte != '\r' && tap.line.size() < 200) tap.line.push_back(static_cast<char>(byte));
      return;
    }
    if (tap.active && !tap.line.empty() && std::isdigit(static_cast<unsigned char>(tap.line[0]))) {
      const auto& a = r->bench.actuator();
      tap.rows.emplace_back(tap.line, "," + fmtCsvNumber(r->bench.busCurrent_a(), 3) + "," +
                                          fmtCsvNumber(a.rpm(), 0) + "," +
                                          fmtCsvNumber(a.windingTemp_c(), 2));
    }
    tap.line.clear();
  });
}

// The workflow `thrustcal board calibrate` runs, with this scenario's settings.
board::CalibrateOptions calibrateOptionsFor(const GatherOptions& o, const plant::BenchParams& params,
                                            const GatherMotorResult& mr) {
  board::CalibrateOptions co;
  co.slot = mr.slot;
  co.mount_g = static_cast<int>(mr.mount_weight_g);
  co.plate_g = static_cast<int>(std::lround(params.load_cell.plate_g));
  co.model = gatherModelName(o.model);
  co.second_sweep = true;
  co.pwm_min_us = o.pwm_min_us;
  co.pwm_max_us = o.pwm_max_us;
  co.step_us = o.step_us;
  co.settle_ms = o.settle_ms;
  co.settle_auto = o.settle_auto;
  return co;
}

// The two sweeps the client captured: their sample counts and maximum forces into mr, and
// with a log folder their CSV files (the plant's instruments added).
void keepSweeps(const GatherOptions& o, const board::CalibrateResult& cr, const BenchOperator& op,
                GatherMotorResult& mr) {
  for (int i = 0; i < 2; ++i) {
    CurveCheck& c = i == 0 ? mr.curve1 : mr.curve2;
    const board::SweepLog& log = cr.sweeps.at(i);
    c.samples = static_cast<int>(log.rows.size());
    c.sweep_max_g = log.max_force_g;
    if (c.sweep_max_g <= 0)
      throw std::runtime_error(fmt::format("sweep {} on slot {} did not report its max force",
                                           i + 1, mr.slot));
    if (!o.log_dir.empty()) {
      c.csv_path = (std::filesystem::path(o.log_dir) /
                    fmt::format("gather_slot{}_curve{}.csv", mr.slot, i + 1))
                       .string();
      writeSweepCsv(c.csv_path, log, op.rows(i + 1), mr.slot, i + 1);
    }
  }
}

// gather_store as a user's cable reaches it: the board boots from the Mega2560's bootloader
// behind a pty, and `thrustcal board calibrate`'s client code drives the whole workflow.
void gatherOverPty(const GatherOptions& o, const plant::BenchParams& params,
                   const ProgressFn& progress, GatherMotorResult& mr,
                   std::optional<plant::Bench>& truth1, std::optional<plant::Bench>& truth2,
                   std::vector<uint8_t>& eeprom, double& sim_s, double& wall_s) {
  auto rig = std::make_unique<BenchRig>(FlashImages{o.bootloader_hex, o.elf_path}, params, mr.slot);
  rig->board.setEeprom(eeprom);
  InstrumentTap tap;
  tapInstruments(*rig, tap);
  PtyOptions po;
  po.reset_on_open = true;
  PtyBridge link(rig->board, po);
  link.start(Pacing{1.0, 0.0});
  progress(fmt::format("slot {}: motor seed {} ({}), board on {}: reset, bootloader, gather_store",
                       mr.slot, mr.seed, o.preset, link.path()));
  std::array<std::optional<plant::Bench>, 2> truth;
  BenchOperator op(link, *rig, tap, o, progress, mr, truth);
  const board::CalibrateOptions co = calibrateOptionsFor(o, params, mr);
  board::CalibrateResult cr;
  try {
    board::SerialPort port(link.path());
    board::ConsoleClient con(port);
    con.waitForBoot(board::kBootTimeoutS);
    cr = board::calibrate(con, co, op);
    progress(fmt::format("slot {}: cal {} g: {}", mr.slot, mr.mount_weight_g,
                         cr.cal.empty() ? "" : cr.cal.back()));
    eeprom = board::boardEepromDump(con);  // what the user gets back through the cable
  } catch (...) {
    try {
      link.stop();  // a crashed firmware says more than the client's time-out
    } catch (const std::exception& e) {
      throw std::runtime_error(fmt::format("slot {}: {}", mr.slot, e.what()));
    }
    throw;
  }
  link.stop();
  if (eeprom != rig->board.eeprom())
    throw std::runtime_error(fmt::format("slot {}: `eeprom dump` over the pty differs from the "
                                         "simulated EEPROM",
                                         mr.slot));
  mr.store = cr.store;
  mr.show = cr.show;
  keepSweeps(o, cr, op, mr);
  truth1 = truth[0];
  truth2 = truth[1];
  sim_s = rig->board.simulatedSeconds();
  wall_s = rig->board.wallSeconds();
}

}  // namespace

GatherResult runGather(const GatherOptions& o) {
  const ProgressFn progress = o.progress ? o.progress : ProgressFn(stderrProgress);
  if (o.seeds.size() != o.slots.size())
    throw std::invalid_argument(fmt::format("{} seeds but {} slots: give one seed per slot",
                                            o.seeds.size(), o.slots.size()));
  if (!o.log_dir.empty()) std::filesystem::create_directories(o.log_dir);
  const auto session0 = std::chrono::steady_clock::now();
  GatherResult result;
  result.model = o.model;
  result.link = o.link;
  result.eeprom = o.eeprom.empty() ? std::vector<uint8_t>(kEepromBytes, 0xFF) : o.eeprom;
  double sweep_sim = 0, sweep_wall = 0;

  for (std::size_t m = 0; m < o.seeds.size(); ++m) {
    GatherMotorResult mr;
    mr.slot = o.slots[m];
    mr.seed = o.seeds[m];
    if (mr.slot < 0 || mr.slot > 3)
      throw std::invalid_argument(fmt::format("slot {} is not 0..3", mr.slot));
    plant::BenchParams params = plant::BenchParams::thesis(o.preset);
    params.actuator = motorForSeed(o.preset, mr.seed, o.variation);
    params.load_cell.seed = mr.seed * 1000003ULL + 17;
    params.battery_sensor.seed = mr.seed * 1000003ULL + 29;
    if (o.adjust_bench) o.adjust_bench(params);
    mr.mount_weight_g = std::round(params.actuator.mountWeight_g());
    mr.second_source = o.second == SecondCurveSource::kBenchSupply
                           ? fmt::format("bench supply {:.2f} V, 6.32 A limit", o.supply_v)
                           : fmt::format("drained pack, {:.0f} % charge", o.drained_soc * 100);
    std::optional<plant::Bench> truth1, truth2;
    double sim_s = 0, wall_s = 0;
    if (o.link == GatherLink::kPty)
      gatherOverPty(o, params, progress, mr, truth1, truth2, result.eeprom, sim_s, wall_s);
    else
      gatherInProcess(o, params, progress, mr, truth1, truth2, result.eeprom, sim_s, wall_s);
    // Compare the stored curves with the plant.
    namespace gc = gather_checks;
    const std::array<gc::TruthTable, 2> tables = {gc::TruthTable(*truth1), gc::TruthTable(*truth2)};
    const std::array<gc::StoredCurve, 2> stored = gc::storedCurves(result.eeprom, o, tables, mr);
    gc::checkCurve(stored[0], tables[0], o, mr.curve1);
    gc::checkCurve(stored[1], tables[1], o, mr.curve2);
    sweep_sim += mr.curve1.sweep_simulated_s + mr.curve2.sweep_simulated_s;
    sweep_wall += mr.curve1.sweep_wall_s + mr.curve2.sweep_wall_s;
    result.curve_error_max_g =
        std::max({result.curve_error_max_g, mr.curve1.error_max_g, mr.curve2.error_max_g});
    progress(fmt::format(
        "slot {}: stored {} at sweep 1 ({:.3f} V, 1..{} g) max error {:.1f} g, sweep 2 ({:.3f} V, "
        "1..{} g) max error {:.1f} g",
        mr.slot, o.model == GatherModel::kModelV2 ? "model v2" : "curve", mr.curve1.start_v,
        mr.curve1.max_g, mr.curve1.error_max_g, mr.curve2.start_v, mr.curve2.max_g,
        mr.curve2.error_max_g));

    if (!o.log_dir.empty()) gc::writeCurvesCsv(o, stored, tables, mr);
    result.simulated_s += sim_s;
    result.wall_s += wall_s;
    result.motors.push_back(std::move(mr));
  }
  result.realtime_factor = result.wall_s > 0 ? result.simulated_s / result.wall_s : 0;
  result.sweep_realtime_factor = sweep_wall > 0 ? sweep_sim / sweep_wall : 0;
  result.session_wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - session0).count();
  return result;
}

}  // namespace sim

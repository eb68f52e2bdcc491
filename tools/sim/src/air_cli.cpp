// The virtual airframe on the command line: see sim/air_cli.hpp.
#include "sim/air_cli.hpp"
#include "cli_support.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "plant/params.hpp"
#include "hex/intel_hex.hpp"
#include "sim/scenarios.hpp"
#include "sim/twi.hpp"

extern "C" {
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
}

namespace sim {
namespace {

namespace fs = std::filesystem;

bool isMotorFault(const AirFault& f) {
  return f.kind == AirFault::Kind::kMotorDead || f.kind == AirFault::Kind::kPropLoss;
}

std::vector<AirFault> parseFaults(const AirCliOptions& o) {
  std::vector<AirFault> faults;
  for (const std::string& spec : o.faults) faults.push_back(parseAirFault(spec));
  return faults;
}

// "--OPTION TEXT: " in front of a parser's message once, as CLI11 reports check failures.
std::string checkMessage(const std::invalid_argument& e, const std::string& option) {
  const std::string what = e.what();
  return what.rfind(option + " ", 0) == 0 ? what.substr(option.size() + 1) : what;
}

Mpu6050Params imuParams(const AirCliOptions& o) {
  Mpu6050Params p;
  p.seed = o.imu_seed;
  p.unit_errors = p.noise = !o.imu_ideal;
  return p;
}

// "M:PRESET": motor M (0..3) is that preset instead (its seed's variation kept).
void applyMotorParts(std::array<plant::ActuatorParams, 4>& motors, const AirCliOptions& o,
                     const std::vector<uint64_t>& seeds) {
  for (const std::string& part : o.motor_parts) {
    const std::size_t colon = part.find(':');
    const std::string m = colon == std::string::npos ? "" : part.substr(0, colon);
    if (m.size() != 1 || m[0] < '0' || m[0] > '3')
      throw std::invalid_argument(fmt::format(
          "--motor {}: write M:PRESET with M the motor 0..3, e.g. --motor 2:kv900_11x4.7", part));
    const int i = m[0] - '0';
    motors[i] = motorForSeed(part.substr(colon + 1), seeds.at(i), 0.03);
  }
}

// The log file: '#' lines saying what ran, the header, one row per sample, flushed now and then
// so a person can follow it while the console runs.
struct CsvLog {
  std::ofstream out;
  int rows = 0;
  CsvLog(const std::string& path, const AirframeRig& rig) : out(path, std::ios::trunc) {
    if (!out) throw std::invalid_argument(fmt::format("--log {}: cannot write there; check the directory", path));
    out << "# thrustcal sim: " << rig.describe() << "\n";
    out << "# axes: body x forward, y left, z up; roll + right side down, pitch + nose down, "
           "yaw + nose left; accel = specific force at the IMU (+1 g on z at rest, level)\n";
    for (const AirFault& f : rig.options().faults) out << "# fault: " << f.spec << "\n";
    out << AirframeRig::csvHeader(rig.options().rig == AirRig::kSeesaw ? 2 : 4) << "\n";
  }
  void row(const AirSample& s) {
    out << AirframeRig::csvRow(s) << "\n";
    if (++rows % 20 == 0) out.flush();
  }
};

}  // namespace

void addAirOptions(CLI::App* cmd, AirCliOptions& o) {
  cmd->add_option("--imu", o.imu, "an IMU on the board's I2C bus (SDA D20, SCL D21): none or mpu6050 (at 0x68)")
      ->check(CLI::IsMember({"none", "mpu6050"}))
      ->capture_default_str();
  cmd->add_option("--imu-seed", o.imu_seed, "which MPU-6050 unit: its offsets, scales and noise")
      ->capture_default_str();
  cmd->add_flag("--imu-ideal", o.imu_ideal, "a perfect IMU: no unit errors, no noise");
  cmd->add_option("--layout", o.layout, "gimbal: the motors in plus or x layout")
      ->check(CLI::IsMember({"plus", "x"}))
      ->capture_default_str();
  cmd->add_option("--fault", o.faults, std::string("inject a fault, repeatable: ") + kAirFaultSyntax)
      ->check([](const std::string& spec) -> std::string {  // errors at parse time
        try {
          parseAirFault(spec);
          return {};
        } catch (const std::invalid_argument& e) {
          return checkMessage(e, "--fault");  // CLI11 puts "--fault: " in front already
        }
      });
  cmd->add_option("--log", o.log, "seesaw/gimbal: write the rig's true attitude, rates, motor forces "
                                  "and pulses to this CSV while it runs");
  cmd->add_option("--log-period", o.log_period_s, "seconds between log rows")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--motor", o.motor_parts, "seesaw/gimbal: M:PRESET makes motor M another part, "
                                            "e.g. 2:kv900_11x4.7 (repeatable)");
  cmd->add_option("--spin", o.spin, "gimbal: each motor's propeller direction, cw or ccw seen from above, motor 0 "
                                    "first, e.g. cw,ccw,cw,ccw (default: the layout's, docs/sim.md)");
  cmd->add_option("--imu-mount", o.imu_mount, std::string("the IMU's rotation against the airframe: ") + kImuMountSyntax)
      ->check([](const std::string& spec) -> std::string {
        try {
          parseImuMount(spec);
          return {};
        } catch (const std::invalid_argument& e) {
          return checkMessage(e, "--imu-mount");
        }
      })
      ->capture_default_str();
  cmd->add_option("--rc", o.rc, std::string("an RC receiver on these pins: ") + kRcSpecSyntax +
                                  "; no signal until a value comes (docs/sim.md, \"RC receiver input\")")
      ->check([](const std::string& spec) -> std::string {
        try {
          parseRcSpec(spec, nullptr);  // against the ESC pins (--esc-pins) when the board is made
          return {};
        } catch (const std::invalid_argument& e) {
          return checkMessage(e, "--rc");
        }
      });
  cmd->add_option("--rc-script", o.rc_script, "the receiver's channel values over simulated time: CSV "
                                              "t_s,ch1..ch8 (us), a row T,loss stops the signal")
      ->check(CLI::ExistingFile);
  cmd->add_option("--vibration", o.vibration_g, "seesaw/gimbal: rotor imbalance at the IMU, g at 10,000 rpm")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--esc-pins", o.esc_pins,
                  "the Arduino pins of ESC outputs 0..3, the rig's motors 0..3, e.g. D3,D5,D6,D2 "
                  "(default: the board table, D6,D7,D8,D11); pulses are timed from the pins' edges")
      ->check([](const std::string& list) -> std::string {  // errors at parse time
        try {
          parseEscPins(list);
          return {};
        } catch (const std::invalid_argument& e) {
          const std::string what = e.what();
          return what.rfind("--esc-pins ", 0) == 0 ? what.substr(11) : what;
        }
      });
}

void applyEscPins(Board& board, const AirCliOptions& o) {
  if (!o.esc_pins.empty()) board.setEscPins(parseEscPins(o.esc_pins));
}

bool isAirRig(const std::string& rig) { return rig == "seesaw" || rig == "gimbal"; }

std::vector<int> parseSpin(const std::string& text, int motors) {
  std::vector<int> spin;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string word = text.substr(start, comma - start);
    start = comma + 1;
    if (word != "cw" && word != "ccw")
      throw std::invalid_argument(fmt::format("--spin {}: '{}' is neither cw nor ccw; write one direction per motor, "
                                              "seen from above, e.g. --spin cw,ccw,cw,ccw",
                                              text, word));
    spin.push_back(word == "ccw" ? 1 : -1);
  }
  if (static_cast<int>(spin.size()) != motors)
    throw std::invalid_argument(fmt::format("--spin {}: {} directions for a rig with {} motors; write one per motor, "
                                            "motor 0 first", text, spin.size(), motors));
  return spin;
}

std::unique_ptr<AirframeRig> makeAirframeRig(const std::string& elf, const std::string& rig,
                                             const std::string& preset,
                                             const std::vector<uint64_t>& seeds,
                                             const AirCliOptions& o) {
  AirframeOptions a;
  a.rig = rig == "seesaw" ? AirRig::kSeesaw : AirRig::kGimbal;
  a.gimbal.layout = o.layout == "plus" ? plant::Layout::kPlus : plant::Layout::kX;
  a.gimbal.common.vibration_g_at_10krpm = a.seesaw.common.vibration_g_at_10krpm = o.vibration_g;
  std::vector<uint64_t> s = seeds;
  for (uint64_t i = s.size(); i < 4; ++i) s.push_back(i + 1);
  for (int i = 0; i < 4; ++i) a.motors[i] = motorForSeed(preset, s[i], 0.03);
  applyMotorParts(a.motors, o, s);
  if (!o.spin.empty()) {
    if (a.rig == AirRig::kSeesaw)
      throw std::invalid_argument("--spin: the seesaw turns about its pivot only, where the propellers' directions "
                                  "make no torque; use --spin with --rig gimbal");
    a.gimbal.common.spin = parseSpin(o.spin, 4);
  }
  a.imu = o.imu == "mpu6050";
  a.imu_params = imuParams(o);
  a.imu_mount = parseImuMount(o.imu_mount);
  if (!o.esc_pins.empty()) a.esc_pins = parseEscPins(o.esc_pins);
  a.faults = parseFaults(o);
  a.log_period_s = o.log.empty() ? 0.0 : o.log_period_s;
  a.log_in_memory = false;
  auto made = std::make_unique<AirframeRig>(elf, a);
  if (!o.log.empty()) {
    if (fs::path(o.log).has_parent_path()) fs::create_directories(fs::path(o.log).parent_path());
    auto log = std::make_shared<CsvLog>(o.log, *made);
    made->onSample([log](const AirSample& row) { log->row(row); });
  }
  return made;
}

// --- RC input ---

std::unique_ptr<RcOnBoard> makeRcInput(Board& board, const AirCliOptions& o, bool pty) {
  if (o.rc.empty()) {
    if (!o.rc_script.empty() || o.rc_pty)
      throw std::invalid_argument(fmt::format("{} needs a receiver: add --rc ppm:PIN or --rc pwm:PIN,PIN,...",
                                              o.rc_script.empty() ? "--rc-pty" : "--rc-script"));
    return nullptr;
  }
  std::vector<RcScriptRow> rows;
  if (!o.rc_script.empty()) rows = readRcScript(o.rc_script);  // errors before the board runs
  auto rc = std::make_unique<RcOnBoard>(board, parseRcSpec(o.rc, &board.escPins()));
  if (!rows.empty()) rc->play(std::move(rows));
  if (pty || o.rc_pty) rc->openPty();
  return rc;
}

std::string rcSummary(const RcOnBoard& rc) {
  constexpr std::size_t kShown = 20;
  const auto& a = rc.applied();
  std::string s = fmt::format("rc: {}, {} changes applied, {} frames sent", rc.describe(), a.size(), rc.part().frames);
  for (std::size_t i = 0; i < a.size() && i < kShown; ++i) s += "\n  rc " + a[i];
  if (a.size() > kShown) s += fmt::format("\n  ... {} more", a.size() - kShown);
  return s;
}

// --- a board without a rig ---

StillAirframe::StillAirframe(Board& board, const std::string& rig, const AirCliOptions& o) : board_(board) {
  if (!o.log.empty())
    throw std::invalid_argument(fmt::format("--log records a rig's attitude: use --rig seesaw or "
                                            "gimbal (the {} stands still)", rig));
  if (!o.motor_parts.empty() || o.vibration_g > 0 || !o.spin.empty())
    throw std::invalid_argument("--motor, --vibration and --spin need --rig seesaw or gimbal");
  for (const AirFault& f : parseFaults(o)) {
    if (isMotorFault(f))
      throw std::invalid_argument(fmt::format("--fault {}: motor faults need --rig seesaw or gimbal", f.spec));
    if (f.kind != AirFault::Kind::kSdaLow && o.imu != "mpu6050")
      throw std::invalid_argument(fmt::format("--fault {}: there is no IMU on the board; add --imu mpu6050", f.spec));
    pending_.push_back(f);
  }
  std::stable_sort(pending_.begin(), pending_.end(), [](auto& a, auto& b) { return a.at_s < b.at_s; });
  if (o.imu == "mpu6050")
    imu_ = std::make_unique<ImuOnBoard>(board_, imuParams(o), levelAtRest(), parseImuMount(o.imu_mount));
  std::weak_ptr<int> alive = alive_;
  board_.addResetListener([this, alive](uint64_t) {
    if (!alive.expired()) arm();  // a reset cancelled the cycle timer
  });
  arm();
}

StillAirframe::~StillAirframe() { avr_cycle_timer_cancel(board_.avr(), &StillAirframe::onFaultTime, this); }

void StillAirframe::arm() {
  avr_cycle_timer_cancel(board_.avr(), &StillAirframe::onFaultTime, this);
  if (pending_.empty()) return;
  const uint64_t at = secondsToCycles(pending_.front().at_s);
  const uint64_t now = board_.cycle();
  avr_cycle_timer_register(board_.avr(), at > now ? at - now : 1, &StillAirframe::onFaultTime, this);
}

uint64_t StillAirframe::onFaultTime(avr_t*, uint64_t, void* param) {
  auto* self = static_cast<StillAirframe*>(param);
  while (!self->pending_.empty() && secondsToCycles(self->pending_.front().at_s) <= self->board_.cycle()) {
    const AirFault f = self->pending_.front();
    self->pending_.erase(self->pending_.begin());
    if (f.kind == AirFault::Kind::kImuNack) self->imu_->chip().setNack(true);
    if (f.kind == AirFault::Kind::kImuFreeze) self->imu_->chip().setFrozen(true);
    if (f.kind == AirFault::Kind::kSdaLow) self->board_.twi().holdSdaLow(f.release_clocks);
    self->applied_.push_back(fmt::format("t={:.4f} s {}", self->board_.timeS(), f.spec));
    if (self->fault_listener_) self->fault_listener_(self->applied_.back());
  }
  self->arm();
  return 0;
}

// --- thrustcal sim run ---

namespace {

std::atomic<bool> g_run_stop{false};
extern "C" void onRunSignal(int) { g_run_stop = true; }

struct RunOptions {
  std::string elf, eeprom, rig = "none", preset = "kv1100_9x4.7";
  std::vector<uint64_t> seeds{1, 2, 3, 4};
  std::vector<std::string> send;
  double duration_s = 0.0;
  bool quiet = false;
  AirCliOptions air;
};

void runOnce(const RunOptions& r) {
  std::unique_ptr<AirframeRig> rig;
  std::unique_ptr<Board> bare;
  Board* board = nullptr;
  if (isAirRig(r.rig)) {
    rig = makeAirframeRig(r.elf, r.rig, r.preset, r.seeds, r.air);
    board = &rig->board();
  } else {
    bare = std::make_unique<Board>(r.elf);
    board = bare.get();
    applyEscPins(*board, r.air);
  }
  std::unique_ptr<StillAirframe> still;
  if (!rig) still = std::make_unique<StillAirframe>(*board, r.rig, r.air);
  const std::unique_ptr<RcOnBoard> rc = makeRcInput(*board, r.air, false);
  if (rc && !rc->ptyPath().empty())
    fmt::print(stderr, "sim run: RC receiver {}; live channel values: type 'ch 1500 1500 1000 1500' lines on {}\n",
               rc->describe(), rc->ptyPath());
  if (!r.eeprom.empty()) board->setEeprom(hex::readIntelHexFile(r.eeprom, kEepromBytes));
  if (!r.quiet)
    board->addOutputListener([](uint8_t b) {
      if (b != '\r') std::fputc(b, stdout);
    });
  const auto say_fault = [](const std::string& f) { fmt::print(stderr, "fault applied: {}\n", f); };
  if (rig) rig->onFaultApplied(say_fault);
  if (still) still->onFaultApplied(say_fault);
  for (const std::string& line : r.send) board->sendText(line + "\r");
  std::signal(SIGINT, onRunSignal);
  const double end = r.duration_s;
  while (board->timeS() < end && !g_run_stop) board->runFor(std::min(0.05, end - board->timeS()));
  std::fflush(stdout);
  fmt::print(stderr, "sim run: {:.3f} s simulated in {:.2f} s wall ({}); {}\n",
             board->simulatedSeconds(), board->wallSeconds(), speedText(board->realtimeFactor()),
             rig ? rig->describe() : fmt::format("no rig, IMU {}", r.air.imu));
  if (rc) fmt::print(stderr, "  {}\n", rcSummary(*rc));
  if (!r.air.log.empty()) fmt::print(stderr, "  truth log: {}\n", r.air.log);
}

}  // namespace

void addRunCommand(CLI::App& sim) {
  auto* cmd = sim.add_subcommand(
      "run",
      "Run any firmware image for a while, without a terminal: its UART0 output goes to stdout,\n"
      "--send lines go to its UART0 at the start. With --imu mpu6050 an MPU-6050 sits on its I2C\n"
      "bus; --rig seesaw|gimbal puts it on an attitude rig (ESC i drives motor i) that the IMU\n"
      "measures, and --log records the rig's true attitude. Simulated time only: the same\n"
      "command gives the same output.");
  auto r = std::make_shared<RunOptions>();
  cmd->add_option("--elf", r->elf, "firmware ELF image")->required()->check(CLI::ExistingFile);
  cmd->add_option("--eeprom", r->eeprom, "Intel HEX EEPROM image to load")->check(CLI::ExistingFile);
  cmd->add_option("--rig", r->rig, "none (a board on the desk), seesaw or gimbal")
      ->check(CLI::IsMember({"none", "seesaw", "gimbal"}))
      ->capture_default_str();
  cmd->add_option("--preset", r->preset, "motor + propeller preset")->capture_default_str();
  cmd->add_option("--seeds", r->seeds, "motor seeds, ESC 0..3 (3 % part-to-part variation)")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--duration", r->duration_s, "simulated seconds to run")->required()->check(CLI::PositiveNumber);
  cmd->add_option("--send", r->send, "a line typed into UART0 at the start (repeatable; Enter = CR)");
  cmd->add_flag("--quiet", r->quiet, "do not copy the UART output to stdout");
  addAirOptions(cmd, r->air);
  cmd->add_flag("--rc-pty", r->air.rc_pty, "with --rc: also open the live RC pseudo-terminal (sim console "
                                           "always does)");
  cmd->callback([r] { guarded("run", [&] { runOnce(*r); }); });
}

}  // namespace sim

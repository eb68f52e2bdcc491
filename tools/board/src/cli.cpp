// `thrustcal board flash|eeprom put|eeprom get|calibrate|liftoff` (and params: params_cli.cpp).
#include "board/cli.hpp"
#include "hal/board.hpp"
#include "thrustcal/record_limits.hpp"
#include "thrustcal/sweep_rules.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "board/calibrate.hpp"
#include "board/cli_support.hpp"
#include "board/liftoff.hpp"
#include "board/transfer.hpp"
#include "lab/analysis.hpp"
#include "lab/dataset.hpp"
#include "lab/model.hpp"
#include "hex/intel_hex.hpp"

namespace board {
namespace {

namespace fs = std::filesystem;

std::string fmtDuration(double s) {
  if (!std::isfinite(s) || s < 0) s = 0;
  const int t = static_cast<int>(s + 0.5);
  return fmt::format("{}:{:02d}", t / 60, t % 60);
}

// Reads one line from the terminal; false when stdin is not a terminal or at EOF.
bool askTerminal(const std::string& question, std::string& answer) {
  if (!::isatty(STDIN_FILENO)) return false;
  std::fprintf(stderr, "%s", question.c_str());
  std::fflush(stderr);
  const bool got = static_cast<bool>(std::getline(std::cin, answer));
  if (interruptRequested()) throw Interrupted("interrupted at the question; nothing was started");
  return got;
}

// The person at the bench, on this terminal.
class TerminalOperator : public Operator {
 public:
  explicit TerminalOperator(bool yes) : yes_(yes), tty_(::isatty(STDERR_FILENO)) {}
  bool confirmSpin(const std::string& what) override {
    if (yes_) {
      info(what + " (--yes)");
      return true;
    }
    std::string answer;
    if (!askTerminal(fmt::format("board: {}.\n       Clear the propeller's path. Type yes to "
                                 "spin it: ",
                                 what),
                     answer))
      throw std::runtime_error(fmt::format("{}: needs a yes from a terminal (stdin is not one); "
                                           "pass --yes to skip the question",
                                           what));
    return answer == "yes" || answer == "y";
  }
  void prepareSecondSweep(const std::string& what) override {
    std::string answer;
    if (!askTerminal(fmt::format("board: {}; then press Enter: ", what), answer))
      throw std::runtime_error(fmt::format("the second sweep needs you at the bench ({}); run "
                                           "from a terminal",
                                           what));
  }
  void sweepStarting(int sweep) override {
    sweep_ = sweep;
    last_print_rows_ = 0;
  }
  void sweepEnded(int, const SweepLog& log) override {
    if (tty_) std::fprintf(stderr, "\n");
    info(fmt::format("sweep {}: {} rows, max force {:.1f} g, {:.1f} s", sweep_, log.rows.size(),
                     log.max_force_g, log.wall_s));
  }
  void progress(const SweepProgress& p) override {
    const double frac = p.rows_total > 0 ? static_cast<double>(p.rows) / p.rows_total : 0;
    const int width = 24, full = static_cast<int>(frac * width + 0.5);
    const std::string bar = std::string(full, '#') + std::string(width - full, '-');
    const std::string text = fmt::format("sweep {} [{}] {:3}/{} {:4} us {:7.1f} g  ETA {}", p.sweep,
                                         bar, p.rows, p.rows_total, p.pwm_us, p.force_g,
                                         fmtDuration(p.eta_s));
    if (tty_) {
      std::fprintf(stderr, "\r%s ", text.c_str());
      std::fflush(stderr);
    } else if (p.rows - last_print_rows_ >= 10 || p.rows == p.rows_total) {
      last_print_rows_ = p.rows;
      info(text);
    }
  }
  void note(const std::string& line) override {
    if (line.rfind("# ", 0) == 0 && line.find("steps, max force") != std::string::npos) return;
    if (tty_ && sweep_ > 0) std::fprintf(stderr, "\r");
    info(line);
  }

 private:
  bool yes_, tty_;
  int sweep_ = 0;
  int last_print_rows_ = 0;
};

std::unique_ptr<ConsoleClient> openConsole(const std::string& port, std::unique_ptr<SerialPort>& sp,
                                           std::vector<std::string>* boot = nullptr) {
  sp = std::make_unique<SerialPort>(port);
  auto con = std::make_unique<ConsoleClient>(*sp);
  info(fmt::format("{}: reset; waiting for the firmware's prompt", port));
  auto lines = con->waitForBoot(kBootTimeoutS);
  if (boot) *boot = lines;
  info(fmt::format("{} answers ({})", imageName(con->image()), con->prompt()));
  return con;
}

void writeFile(const std::string& path, const std::string& text) {
  if (fs::path(path).has_parent_path()) fs::create_directories(fs::path(path).parent_path());
  std::ofstream out(path, std::ios::trunc);
  if (!out || !(out << text).flush())
    throw std::runtime_error(fmt::format("{}: cannot write; check the directory", path));
}

// The lab's diagnosis of the captured sweeps.
nlohmann::json diagnoseSweeps(const std::vector<std::string>& csvs, const std::string& spec_text) {
  nlohmann::json j;
  lab::ReadOptions ro;
  lab::Dataset data = lab::readFiles(csvs, ro);
  lab::addDerivedColumns(data);
  const lab::ModelSpec spec = lab::parseSpec(spec_text);
  const lab::Diagnosis d = lab::diagnose(data, spec, lab::Holdout::kNone);
  std::printf("lab: model %s on %zu samples: RMSE %.2f g (%.2f %% of the largest force), max %.2f g\n",
              d.fit.model.c_str(), d.fit.n, d.fit.rmse_g, d.fit.rmse_pct, d.fit.max_g);
  for (const auto& w : d.fit.warnings) std::printf("  note: %s\n", w.c_str());
  j = {{"model", d.fit.model}, {"rmse_g", d.fit.rmse_g}, {"max_g", d.fit.max_g}, {"n", d.fit.n}};
  nlohmann::json suspects = nlohmann::json::array();
  int k = 0;
  for (const auto& s : d.variables) {
    if (!s.significant) continue;
    std::printf("  %d. %-12s score %.3f -> %s: %s\n", ++k, s.variable.c_str(), s.score,
                fmt::format("{}", fmt::join(s.effects, ", ")).c_str(), s.advice.c_str());
    suspects.push_back({{"variable", s.variable}, {"score", s.score}, {"effects", s.effects}});
  }
  if (k == 0) std::printf("  no logged variable explains a significant part of what the model misses\n");
  std::printf("  verdict: %s\n", d.verdict_text.c_str());
  std::string files;
  for (const auto& c : csvs) files += c + " ";
  std::printf("more: thrustcal lab ladder %s--model curve --add deadband --add voltage\n",
              files.c_str());
  j["suspects"] = suspects;
  j["noise_g"] = d.noise.known() ? nlohmann::json(d.noise.sigma_g) : nlohmann::json(nullptr);
  j["verdict"] = lab::verdictName(d.verdict);
  return j;
}

void addFlash(CLI::App& board) {
  auto* cmd = board.add_subcommand(
      "flash",
      fmt::format("Write a firmware image through the Mega2560's stock bootloader: avrdude -p m2560 "
                  "-c wiring\n-b {} -D -U flash:w:IMAGE:i (its verify included), then open the port "
                  "again and wait\nfor the image's prompt.",
                  hal::kBootloaderBaud));
  auto port = std::make_shared<std::string>();
  auto image = std::make_shared<std::string>();
  auto timeout = std::make_shared<double>(180.0);
  auto no_check = std::make_shared<bool>(false);
  cmd->add_option("--port,-P", *port, "serial port (/dev/ttyACM0; a simulated board's pty or link)")
      ->required();
  cmd->add_option("IMAGE", *image, "Intel HEX image, e.g. build/avr/firmware/read_run/read_run.hex")
      ->required();
  cmd->add_option("--timeout", *timeout, "give avrdude this many seconds")->capture_default_str();
  cmd->add_flag("--no-check", *no_check, "do not wait for the image's prompt afterwards");
  cmd->callback([=] {
    guarded([&] {
      installInterruptHandler();
      TransferOptions to;
      to.avrdude_timeout_s = *timeout;
      to.check_prompt = !*no_check;
      to.progress = info;
      const FlashResult r = flashImage(*port, *image, to);
      std::printf("flashed %s (%zu bytes) to %s in %.1f s (avrdude, verify included)%s\n",
                  image->c_str(), r.image_bytes, port->c_str(), r.avrdude.wall_s,
                  r.image == Image::kUnknown
                      ? ""
                      : fmt::format("; {} answers", imageName(r.image)).c_str());
    });
  });
}

void addEeprom(CLI::App& board) {
  auto* ee = board.add_subcommand(
      "eeprom",
      "The board's 4 KiB EEPROM, read and verified through the running firmware (gather_store or\n"
      "read_run: `eeprom dump`, `eeprom crc`), never through the bootloader, whose EEPROM read is\n"
      "broken (arduino/ArduinoCore-avr issue 129).");
  ee->require_subcommand(1);
  {
    auto* put = ee->add_subcommand(
        "put",
        "Write an EEPROM image: made whole (a partial file is completed with what the board holds),\n"
        "written by avrdude without its broken verify (-V), then verified with the firmware's\n"
        "CRCs per slot. Nothing is written when the board already holds the image.");
    auto port = std::make_shared<std::string>();
    auto file = std::make_shared<std::string>();
    auto timeout = std::make_shared<double>(180.0);
    put->add_option("--port,-P", *port, "serial port")->required();
    put->add_option("FILE", *file, "Intel HEX EEPROM image (sim gather --eeprom, lab export)")
        ->required()
        ->check(CLI::ExistingFile);
    put->add_option("--timeout", *timeout, "give avrdude this many seconds")->capture_default_str();
    put->callback([=] {
      guarded([&] {
        installInterruptHandler();
        TransferOptions to;
        to.avrdude_timeout_s = *timeout;
        to.progress = info;
        const EepromPutResult r = putEeprom(*port, *file, to);
        if (r.written)
          std::printf("wrote %s to the EEPROM on %s in %.1f s (avrdude %.1f s; %zu bytes from the "
                      "file, %zu kept from the board) and verified it through %s: %s\n",
                      file->c_str(), port->c_str(), r.wall_s, r.avrdude.wall_s, r.given_bytes,
                      kEepromBytes - r.given_bytes, imageName(r.image), r.crcs.text().c_str());
        else
          std::printf("the EEPROM on %s already holds %s (%s); nothing written\n", port->c_str(),
                      file->c_str(), r.crcs.text().c_str());
      });
    });
  }
  {
    auto* get = ee->add_subcommand(
        "get", "Read the whole EEPROM through the firmware's `eeprom dump` into an Intel HEX file.");
    auto port = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    get->add_option("--port,-P", *port, "serial port")->required();
    get->add_option("-o,--output", *out, "Intel HEX file to write")->required();
    get->callback([=] {
      guarded([&] {
        installInterruptHandler();
        TransferOptions to;
        to.progress = info;
        const EepromGetResult r = getEeprom(*port, to);
        hex::writeIntelHexFile(*out, r.bytes);
        std::printf("read the EEPROM on %s through %s into %s (%.1f s): %s\n", port->c_str(),
                    imageName(r.image), out->c_str(), r.wall_s, r.crcs.text().c_str());
      });
    });
  }
}

// What `board calibrate` reads from its command line.
struct CalibrateArgs {
  std::string port;
  CalibrateOptions o;
  std::vector<int> range;
  std::string settle = std::to_string(tc::kDefaultSettleCapMs);
  std::string out_dir = ".";
  bool yes = false, no_strict = false;
  std::string lab_model, json;
};

void declareCalibrateOptions(CLI::App* cmd, CalibrateArgs& a) {
  CalibrateOptions* o = &a.o;
  cmd->add_option("--port,-P", a.port, "serial port")->required();
  cmd->add_option("--slot", o->slot, "motor slot: ESC output and EEPROM record (0..3)")
      ->required()
      ->check(CLI::Range(0, 3));
  cmd->add_option("--mount-g", o->mount_g, "motor + propeller weight on the plate, g (cal W)")
      ->required()
      ->check(CLI::Range(1, 950));
  cmd->add_option("--model", o->model, "v1: the thesis's curves (store 1/2); v2: store v2")
      ->check(CLI::IsMember({"v1", "v2"}))
      ->capture_default_str();
  cmd->add_flag("--second-sweep", o->second_sweep,
                "a second sweep at another supply voltage (you change the supply in between)");
  cmd->add_option("--plate-g", o->plate_g, "the load cell's plate weight, g")->capture_default_str();
  cmd->add_option("--range", a.range,
                  fmt::format("sweep PWM MIN MAX in us (default {} {}: the 13 sag bins then span "
                              "where motors fly)",
                              o->pwm_min_us, o->pwm_max_us))
      ->expected(2);
  cmd->add_option("--step", o->step_us, "sweep step, us")->capture_default_str();
  cmd->add_option("--settle", a.settle,
                  fmt::format("per step: MS, or auto (next step once the force stops changing, {} ms "
                              "cap); the thesis's 200 ms leaves the load cell's low-pass ~1 % behind",
                              tc::kDefaultSettleCapMs))
      ->capture_default_str();
  cmd->add_option("--out-dir", a.out_dir, "where calibrate_slotK_sweepN.csv go")->capture_default_str();
  cmd->add_flag("--yes,-y", a.yes, "do not ask before spinning the propeller");
  cmd->add_flag("--no-strict", a.no_strict, "plain console lines even if the firmware offers checksums");
  cmd->add_option("--lab-model", a.lab_model,
                  "model the lab diagnoses the sweeps with (default: thesis for v1, "
                  "curve+deadband+voltage for v2)");
  cmd->add_option("--json", a.json, "the run as JSON (sweeps, store, show, lab)");
}

CalibrateOptions calibrateOptionsFrom(const CalibrateArgs& a) {
  CalibrateOptions opt = a.o;
  if (a.range.size() == 2) {
    opt.pwm_min_us = a.range[0];
    opt.pwm_max_us = a.range[1];
  }
  if (a.settle == "auto") {
    opt.settle_auto = true;
  } else {
    try {
      opt.settle_ms = std::stoi(a.settle);
    } catch (...) {
      throw std::invalid_argument(fmt::format("--settle {}: a number of ms or auto", a.settle));
    }
  }
  opt.strict = !a.no_strict;
  return opt;
}

// Each sweep as a CSV in --out-dir; returns their paths, and their summary in `sweeps`.
std::vector<std::string> writeSweepLogs(const CalibrateArgs& a, int slot, const CalibrateResult& r,
                                        nlohmann::json& sweeps) {
  std::vector<std::string> csvs;
  sweeps = nlohmann::json::array();
  for (std::size_t i = 0; i < r.sweeps.size(); ++i) {
    const std::string path =
        (fs::path(a.out_dir) / fmt::format("calibrate_slot{}_sweep{}.csv", slot, i + 1)).string();
    writeFile(path, r.sweeps[i].csv(fmt::format("thrustcal board calibrate: {} motor {} sweep {}",
                                                a.port, slot, i + 1)));
    csvs.push_back(path);
    sweeps.push_back({{"csv", path},
                      {"rows", r.sweeps[i].rows.size()},
                      {"max_force_g", r.sweeps[i].max_force_g},
                      {"wall_s", r.sweeps[i].wall_s}});
  }
  return csvs;
}

void printCalibration(const CalibrateArgs& a, const CalibrateOptions& opt, const CalibrateResult& r,
                      const std::vector<std::string>& csvs) {
  std::printf("calibrated motor %d on %s (%s, %zu sweep%s, %.1f s%s):\n", opt.slot, a.port.c_str(),
              opt.model.c_str(), r.sweeps.size(), r.sweeps.size() == 1 ? "" : "s", r.wall_s,
              r.checksums ? ", checksummed lines" : "");
  for (const auto& l : r.store) std::printf("  %s\n", l.c_str());
  for (const auto& l : r.show) std::printf("  %s\n", l.c_str());
  for (const auto& c : csvs) std::printf("  sweep log: %s\n", c.c_str());
  std::fflush(stdout);
}

// The model lab's diagnosis of the captured sweeps (an error is reported, not thrown).
nlohmann::json diagnoseCalibration(const CalibrateArgs& a, const CalibrateOptions& opt,
                                   const std::vector<std::string>& csvs) {
  const std::string spec = !a.lab_model.empty() ? a.lab_model
                           : opt.model == "v2"  ? "curve+deadband+voltage"
                                                : "thesis";
  try {
    return diagnoseSweeps(csvs, spec);
  } catch (const std::exception& e) {
    std::printf("lab: no diagnosis: %s\n", e.what());
    return {{"error", e.what()}};
  }
}

void runCalibrateCommand(const CalibrateArgs& a) {
  installInterruptHandler();
  const CalibrateOptions opt = calibrateOptionsFrom(a);
  std::unique_ptr<SerialPort> sp;
  std::vector<std::string> boot;
  auto con = openConsole(a.port, sp, &boot);
  TerminalOperator op(a.yes);
  const CalibrateResult r = calibrate(*con, opt, op);
  nlohmann::json sweeps;
  const std::vector<std::string> csvs = writeSweepLogs(a, opt.slot, r, sweeps);
  printCalibration(a, opt, r, csvs);
  const nlohmann::json lab_json = diagnoseCalibration(a, opt, csvs);
  if (a.json.empty()) return;
  const nlohmann::json j = {{"port", a.port},        {"slot", opt.slot},
                            {"model", opt.model},    {"checksums", r.checksums},
                            {"sweeps", sweeps},      {"store", r.store},
                            {"show", r.show},        {"cal", r.cal},
                            {"wall_s", r.wall_s},    {"lab", lab_json}};
  writeFile(a.json, j.dump(2) + "\n");
}

void addCalibrate(CLI::App& board) {
  auto* cmd = board.add_subcommand(
      "calibrate",
      "Calibrate one motor on the load-cell bench with gather_store (thesis fig. 6.8): motor K,\n"
      "plate, range, step, settle, cal W (tares), sweep -> store 1 (v1) or store v2; with\n"
      "--second-sweep you change the supply, then tare, sweep -> store 2 / store v2; show. Each\n"
      "sweep is streamed to a CSV with a progress bar; asks before a propeller spins (--yes\n"
      "skips); Ctrl-C and a time-out send the abort key; a lost port is opened again if it comes\n"
      "back within 3 s (the open resets the board) and the abort key sent. Ends with the model\n"
      "lab's diagnosis of the captured sweeps.");
  auto a = std::make_shared<CalibrateArgs>();
  declareCalibrateOptions(cmd, *a);
  cmd->callback([a] { guarded([&] { runCalibrateCommand(*a); }); });
}

void addLiftoff(CLI::App& board) {
  auto* cmd = board.add_subcommand(
      "liftoff",
      "The thesis's tethered lift-off on read_run: stream on, liftoff G RAMP HOLD (all four motors\n"
      "to G grams each), stream off. Logs the stream (t_s, four PWMs, battery) and every '#' line\n"
      "to a CSV. Asks before the propellers spin (--yes skips); Ctrl-C sends the abort key.");
  auto port = std::make_shared<std::string>();
  auto o = std::make_shared<LiftoffOptions>();
  auto out = std::make_shared<std::string>("liftoff.csv");
  auto yes = std::make_shared<bool>(false);
  auto no_strict = std::make_shared<bool>(false);
  cmd->add_option("--port,-P", *port, "serial port")->required();
  cmd->add_option("--force", o->force_g, "grams per motor (1..5000, as read_run)")->required()->check(CLI::Range(1, int{tc::kRecordMaxForceG}));
  cmd->add_option("--ramp-ms", o->ramp_ms, "ramp time")->capture_default_str();
  cmd->add_option("--hold-ms", o->hold_ms, "hold time")->capture_default_str();
  cmd->add_option("-o,--output", *out, "CSV log of the stream")->capture_default_str();
  cmd->add_flag("--yes,-y", *yes, "do not ask before spinning the propellers");
  cmd->add_flag("--no-strict", *no_strict, "plain console lines even if the firmware offers checksums");
  cmd->callback([=] {
    guarded([&] {
      installInterruptHandler();
      LiftoffOptions opt = *o;
      opt.strict = !*no_strict;
      std::unique_ptr<SerialPort> sp;
      std::vector<std::string> boot;
      auto con = openConsole(*port, sp, &boot);
      for (const auto& l : boot)
        if (!l.empty()) info(l);
      TerminalOperator op(*yes);
      LiftoffLog log = flyLiftoff(
          *con, opt, [&](const std::string& what) { return op.confirmSpin(what); },
          [](const std::string& l) {
            if (l.rfind("# ", 0) == 0) info(l.substr(2));
          });
      log.boot = boot;
      writeFile(*out, log.csv(fmt::format("thrustcal board liftoff: {} {} g ramp {} ms hold {} ms",
                                          *port, opt.force_g, opt.ramp_ms, opt.hold_ms)));
      std::printf("lift-off at %d g per motor on %s: done, %zu stream rows in %s (%.1f s%s)\n",
                  opt.force_g, port->c_str(), log.rows.size(), out->c_str(), log.wall_s,
                  log.checksums ? ", checksummed lines" : "");
    });
  });
}

}  // namespace

void registerCommands(CLI::App& app) {
  auto* board = app.add_subcommand(
      "board",
      "A Mega2560 on a serial port (a real board on USB, or `thrustcal sim board`): flash images\n"
      "through its stock bootloader, put and get its EEPROM through the firmware, calibrate a\n"
      "motor on the bench, fly the lift-off, move fly's saved parameters as a text file. Every\n"
      "command resets the board when it opens the port (as avrdude and the Arduino IDE do) and\n"
      "waits for the firmware's prompt.");
  board->require_subcommand(1);
  addFlash(*board);
  addEeprom(*board);
  addCalibrate(*board);
  addLiftoff(*board);
  addParams(*board);
}

}  // namespace board

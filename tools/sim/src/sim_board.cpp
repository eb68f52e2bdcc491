// `thrustcal sim board`: see sim/sim_board.hpp.
#include "sim/sim_board.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cstring>

#include <fmt/format.h>

#include "plant/bench.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"

namespace sim {

namespace {

bool contains(const std::vector<uint8_t>& flash, uint32_t end, const char* text) {
  const auto* b = reinterpret_cast<const uint8_t*>(text);
  const auto last = flash.begin() + std::min<std::size_t>(end, flash.size());
  return std::search(flash.begin(), last, b, b + std::strlen(text)) != last;
}

}  // namespace

FlashApp identifyApp(const std::vector<uint8_t>& flash, uint32_t boot_address) {
  const uint32_t end = boot_address != 0 ? boot_address : static_cast<uint32_t>(flash.size());
  if (std::all_of(flash.begin(), flash.begin() + std::min<std::size_t>(end, flash.size()),
                  [](uint8_t b) { return b == 0xFF; }))
    return FlashApp::kNone;
  // The prompts (TEAM.md's console protocol) live in flash as PROGMEM strings.
  const bool gs = contains(flash, end, "gs> ");
  const bool rr = contains(flash, end, "rr> ");
  if (gs && !rr) return FlashApp::kGatherStore;
  if (rr && !gs) return FlashApp::kReadRun;
  return FlashApp::kOther;
}

const char* flashAppName(FlashApp app) {
  switch (app) {
    case FlashApp::kNone: return "nothing (bootloader only)";
    case FlashApp::kGatherStore: return "gather_store";
    case FlashApp::kReadRun: return "read_run";
    default: return "an unknown application";
  }
}

SimBoard::SimBoard(SimBoardOptions options) : o_(std::move(options)) {
  if (o_.rig != "auto" && o_.rig != "bench" && o_.rig != "quad")
    throw std::invalid_argument(fmt::format("rig {}: use auto, bench or quad", o_.rig));
  if (o_.bench_slot < 0 || o_.bench_slot > 3)
    throw std::invalid_argument(fmt::format("slot {} is not 0..3", o_.bench_slot));
  if (o_.seeds.size() != 4)
    throw std::invalid_argument(fmt::format("{} seeds: give four, one per slot", o_.seeds.size()));
  struct stat st {};
  if (!o_.bootloader_hex.empty() && ::stat(o_.bootloader_hex.c_str(), &st) != 0)
    throw BoardError(fmt::format(
        "{}: no bootloader there; install Debian's Arduino bootloaders (sudo apt-get install "
        "arduino-core-avr; tools/test.sh does) or pass --bootloader",
        o_.bootloader_hex));
  board_ = std::make_unique<Board>(FlashImages{o_.bootloader_hex, o_.application});
  if (!o_.eeprom.empty()) board_->setEeprom(o_.eeprom);
  fitRig();
  PtyOptions po = o_.pty;
  po.reset_on_open = true;
  // read_run keeps time for its failsafe and lift-off by the client's keep-alives: real time
  // while its motors spin (gather_store's sweeps still run as fast as the host allows).
  po.real_time_while = [this] { return app_ == FlashApp::kReadRun && anyEscAbove(*board_); };
  po.on_reset = [this, user = o_.pty.on_reset] {
    fitRig();
    if (user) user();
  };
  link_ = std::make_unique<PtyBridge>(*board_, po);
}

SimBoard::~SimBoard() {
  if (link_) {
    try {
      link_->stop();
    } catch (...) {
    }
  }
  link_.reset();
  if (board_) board_->clearPlantWiring();
}

void SimBoard::fitRig() {
  std::vector<uint8_t> flash = board_->flash();
  if (flash == last_flash_) return;
  last_flash_ = std::move(flash);
  app_ = identifyApp(last_flash_, board_->resetAddress());
  const bool want_quad = o_.rig == "quad" || (o_.rig == "auto" && app_ == FlashApp::kReadRun);
  if ((want_quad && quad_) || (!want_quad && bench_)) {
    if (o_.pty.log)
      o_.pty.log(fmt::format("flash holds {}: plant stays {}", flashAppName(app_), rig_text_));
    return;
  }
  board_->clearPlantWiring();
  bench_.reset();
  quad_.reset();
  if (want_quad) {
    plant::QuadFrameParams qp;
    qp.power = plant::BatteryParams::lipo3s(o_.lipo_soc);
    std::array<plant::ActuatorParams, 4> motors;
    for (int i = 0; i < 4; ++i) motors[i] = motorForSeed(o_.preset, o_.seeds[i], o_.variation);
    quad_ = std::make_unique<QuadRig>(*board_, qp, motors);
    rig_text_ = fmt::format("the tethered quad (motor seeds {} {} {} {}, {} LiPo {:.0f} %)",
                            o_.seeds[0], o_.seeds[1], o_.seeds[2], o_.seeds[3], "3S",
                            o_.lipo_soc * 100);
  } else {
    const uint64_t seed = o_.seeds[o_.bench_slot];
    plant::BenchParams p = plant::BenchParams::thesis(o_.preset);
    p.actuator = motorForSeed(o_.preset, seed, o_.variation);
    p.load_cell.seed = seed * 1000003ULL + 17;  // as the simulated gather seeds them
    p.battery_sensor.seed = seed * 1000003ULL + 29;
    p.power = plant::BatteryParams::lipo3s(o_.lipo_soc);
    bench_ = std::make_unique<BenchRig>(*board_, p, o_.bench_slot);
    rig_text_ = fmt::format("the thesis bench (motor seed {} on ESC {}, mount {:.0f} g, 3S LiPo "
                            "{:.0f} %)",
                            seed, o_.bench_slot, std::round(p.actuator.mountWeight_g()),
                            o_.lipo_soc * 100);
  }
  if (o_.pty.log)
    o_.pty.log(fmt::format("flash holds {}: plant = {}", flashAppName(app_), rig_text_));
}

}  // namespace sim

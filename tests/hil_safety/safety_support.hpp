// Shared by the safety HIL tests (issue 8): the real images in simavr, a calibrated EEPROM
// made on the host with the firmware's own codecs (fast: no gather), an ESC pulse log, hang
// injection by patching the image's flash, and the console checksum.
#pragma once
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hil_support.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/elf_symbols.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/record_v2.hpp"

namespace safety {

// EEPROM storage over a host image, for the firmware's codecs.
struct ImageStorage {
  static std::vector<uint8_t>* image;
  static uint8_t readByte(uint16_t addr) { return (*image)[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) { (*image)[addr] = value; }
};
inline std::vector<uint8_t>* ImageStorage::image = nullptr;

// The battery the quad-less boards read on A1: 12.0 V through the 100k/47k divider.
constexpr double kBatteryV = 12.0;
inline double batteryPinMv(double v = kBatteryV) { return v * 1000.0 * 47.0 / 147.0; }

// Thrust of a plant motor (read_run's host-test plant): F = k ((pwm - 1080) / 1000 * V)^2.
inline double plantForceG(double k, int pwm_us, double v) {
  if (pwm_us <= 1080) return 0.0;
  const double x = (pwm_us - 1080) / 1000.0 * v;
  return k * x * x;
}

// Four calibrated slots: 0 and 1 thesis (v1) records with curves at 12.0 and 10.5 V, 2 and 3
// model v2 fitted on the firmware's own fitter, so both models' paths run.
inline std::vector<uint8_t> calibratedEeprom() {
  std::vector<uint8_t> image(sim::kEepromBytes, 0xFF);
  ImageStorage::image = &image;
  for (uint8_t slot = 0; slot < 4; ++slot) {
    const double k = 12.5 + slot;
    if (slot < 2) {
      auto cal = std::make_unique<tc::MotorCalibration>();
      for (auto [curve, v] : {std::pair<tc::ForceCurveBase*, double>{&cal->first, 12.0},
                              std::pair<tc::ForceCurveBase*, double>{&cal->second, 10.5}}) {
        auto builder = std::make_unique<tc::CurveBuilder<128>>();
        for (int pwm = 1000; pwm <= 2000; pwm += 10)
          builder->add(static_cast<uint16_t>(pwm),
                       static_cast<int16_t>(std::lround(plantForceG(k, pwm, v) * 10.0)));
        EXPECT_EQ(builder->build(*curve).status, tc::BuildStatus::kOk);
        curve->start_mv = static_cast<uint16_t>(v * 1000);
      }
      cal->sag.base_pwm_us = 1000;
      tc::writeRecord<ImageStorage>(slot, *cal);
    } else {
      auto fitter = std::make_unique<tc::ModelV2Fitter<128>>();
      for (int pwm = 1000; pwm <= 2000; pwm += 10)
        fitter->add(static_cast<uint16_t>(pwm),
                    static_cast<int16_t>(std::lround(plantForceG(k, pwm, 12.0) * 10.0)), 12000);
      tc::ModelV2 model;
      EXPECT_EQ(fitter->fit(model).status, tc::FitV2Status::kOk);
      EXPECT_EQ(tc::writeModelV2<ImageStorage>(slot, model).status, tc::WriteV2Status::kWritten);
    }
  }
  ImageStorage::image = nullptr;
  return image;
}

// Every complete ESC pulse: channel, width, end time.
struct Pulse {
  int channel;
  double width_us;
  double end_s;
};

struct PulseLog {
  std::vector<Pulse> pulses;
  explicit PulseLog(sim::Board& board) {
    board.addPulseListener([this](int ch, double w, double t) { pulses.push_back({ch, w, t}); });
  }
  // End of the last pulse wider than `width_us` (any channel), or -1.
  double lastWiderThan(double width_us) const {
    double t = -1;
    for (const Pulse& p : pulses)
      if (p.width_us > width_us) t = std::max(t, p.end_s);
    return t;
  }
  // The widest pulse that ended in [from_s, to_s) on any channel (0 if none).
  double widestBetween(double from_s, double to_s) const {
    double w = 0;
    for (const Pulse& p : pulses)
      if (p.end_s >= from_s && p.end_s < to_s) w = std::max(w, p.width_us);
    return w;
  }
  int countBetween(double from_s, double to_s) const {
    int n = 0;
    for (const Pulse& p : pulses) n += (p.end_s >= from_s && p.end_s < to_s) ? 1 : 0;
    return n;
  }
};

// A hang injected into the real image: the first instruction(s) of a function replaced by a
// jump to itself, with interrupts left on ("rjmp .") or switched off first ("cli; rjmp .").
enum class Hang { kInterruptsOn, kInterruptsOff };

struct HangPatch {
  uint32_t address = 0;
  std::vector<uint8_t> original;
};

inline HangPatch hangFunction(sim::Board& board, const std::string& elf, const std::string& symbol,
                              Hang how) {
  HangPatch p;
  p.address = sim::elfSymbol(elf, symbol).address;
  const std::vector<uint8_t> code = how == Hang::kInterruptsOn
                                        ? std::vector<uint8_t>{0xFF, 0xCF}               // rjmp .
                                        : std::vector<uint8_t>{0xF8, 0x94, 0xFF, 0xCF};  // cli; rjmp .
  p.original = board.flash(p.address, code.size());
  board.patchFlash(p.address, code);
  return p;
}

inline void unpatch(sim::Board& board, const HangPatch& p) { board.patchFlash(p.address, p.original); }

// The console checksum: "f 1 37" -> "f 1 37*53".
inline std::string withSum(const std::string& line) {
  uint8_t x = 0;
  for (char c : line) x ^= static_cast<uint8_t>(c);
  return fmt::format("{}*{:02X}", line, x);
}

inline bool contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

// After a flood: lets the input drain, ends any line it left (a damaged one is rejected: the
// receive ring overflowed), and consumes every reply, so the next command starts clean.
inline void drain(sim::Console& con, double quiet_s = 0.3) {
  sim::Board& board = con.board();
  board.runUntil([&] { return board.pendingInput() == 0; }, sim::secondsToCycles(30));
  board.runFor(quiet_s);
  con.send("");
  board.runFor(0.05);
  while (con.unconsumed().find(con.prompt()) != std::string::npos) con.waitPrompt(0.01);
}

// read_run on a bare board: battery on A1, nothing on A0.
struct ReadRunBoard {
  sim::Board board;
  sim::Console con;
  PulseLog log;
  std::vector<std::string> boot_lines;
  explicit ReadRunBoard(const std::vector<uint8_t>& eeprom)
      : board(hil::imagePath("read_run")), con(board, "rr> "), log(board) {
    board.setAdcSource([](int ch) { return ch == 1 ? batteryPinMv() : 0.0; });
    board.setEeprom(eeprom);
    boot_lines = con.waitPrompt(10.0);
  }
  // Sends an empty line (the keep-alive) every `every_s` for `seconds`.
  void keepAliveFor(double seconds, double every_s = 0.2) {
    const uint64_t end = board.cycle() + sim::secondsToCycles(seconds);
    const uint64_t every = std::max<uint64_t>(1, sim::secondsToCycles(every_s));
    while (board.cycle() < end) {
      con.send("");
      board.run(std::min(every, end - board.cycle()));
    }
  }
};

}  // namespace safety

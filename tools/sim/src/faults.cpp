#include "sim/faults.hpp"

#include <fmt/format.h>

#include <cmath>
#include <memory>
#include <stdexcept>

#include "sim/console.hpp"
#include "sim/elf_symbols.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/eeprom_image.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/record_v2.hpp"

namespace sim {

namespace {

double plantForceG(double k, int pwm_us, double v) {
  if (pwm_us <= 1080) return 0.0;
  const double x = (pwm_us - 1080) / 1000.0 * v;
  return k * x * x;
}

}  // namespace

double batteryPinMv(double volts) { return volts * 1000.0 * 47.0 / 147.0; }

std::vector<uint8_t> calibratedTestEeprom() {
  std::vector<uint8_t> image(kEepromBytes, 0xFF);
  const tc::EepromImage::Use use(image);
  for (uint8_t slot = 0; slot < 4; ++slot) {
    const double k = 12.5 + slot;
    if (slot < 2) {
      auto cal = std::make_unique<tc::MotorCalibration>();
      const std::pair<tc::ForceCurveBase*, double> curves[] = {{&cal->first, 12.0},
                                                               {&cal->second, 10.5}};
      for (const auto& [curve, v] : curves) {
        auto builder = std::make_unique<tc::CurveBuilder<128>>();
        for (int pwm = 1000; pwm <= 2000; pwm += 10)
          builder->add(static_cast<uint16_t>(pwm),
                       static_cast<int16_t>(std::lround(plantForceG(k, pwm, v) * 10.0)));
        if (builder->build(*curve).status != tc::BuildStatus::kOk)
          throw std::logic_error("calibratedTestEeprom: the curve did not build");
        curve->start_mv = static_cast<uint16_t>(v * 1000);
      }
      cal->sag.base_pwm_us = 1000;
      tc::writeRecord<tc::EepromImage>(slot, *cal);
    } else {
      auto fitter = std::make_unique<tc::ModelV2Fitter<128>>();
      for (int pwm = 1000; pwm <= 2000; pwm += 10)
        fitter->add(static_cast<uint16_t>(pwm),
                    static_cast<int16_t>(std::lround(plantForceG(k, pwm, 12.0) * 10.0)), 12000);
      tc::ModelV2 model;
      if (fitter->fit(model).status != tc::FitV2Status::kOk ||
          tc::writeModelV2<tc::EepromImage>(slot, model).status != tc::WriteV2Status::kWritten)
        throw std::logic_error("calibratedTestEeprom: model v2 did not fit or store");
    }
  }
  return image;
}

FlashPatch hangFunction(Board& board, const std::string& elf, const std::string& symbol, Hang how) {
  FlashPatch p;
  p.address = elfSymbol(elf, symbol).address;
  const std::vector<uint8_t> code = how == Hang::kInterruptsOn
                                        ? std::vector<uint8_t>{0xFF, 0xCF}               // rjmp .
                                        : std::vector<uint8_t>{0xF8, 0x94, 0xFF, 0xCF};  // cli; rjmp .
  p.original = board.flash(p.address, code.size());
  board.patchFlash(p.address, code);
  std::weak_ptr<double> hung = p.hung_at_s;
  board.watchPc(p.address, [hung](uint64_t cycle) {
    if (auto h = hung.lock(); h && *h < 0) *h = cyclesToSeconds(cycle);
  });
  return p;
}

void restoreFlash(Board& board, const FlashPatch& patch) {
  if (!patch.original.empty()) board.patchFlash(patch.address, patch.original);
}

std::string withChecksum(const std::string& line) {
  uint8_t x = 0;
  for (char c : line) x ^= static_cast<uint8_t>(c);
  return fmt::format("{}*{:02X}", line, x);
}

namespace {
constexpr const char* kRowChars = "0123456789.,-\r\n";  // read_run's `stream on` rows, line ends
}  // namespace

Answer waitAnswer(Console& con, std::size_t mark, double quiet_s, double budget_s) {
  Board& board = con.board();
  std::size_t text_end = mark;  // the output after mark holds nothing but rows beyond this
  uint64_t still_since = board.cycle();
  const bool settled = board.runUntil(
      [&] {
        const std::string& out = board.output();
        if (out.find(con.prompt(), mark) != std::string::npos) return true;
        const std::size_t last_text = out.find_last_not_of(kRowChars);
        const std::size_t end = last_text == std::string::npos || last_text < mark ? mark : last_text + 1;
        if (end != text_end || board.pendingInput() != 0) {
          text_end = end;
          still_since = board.cycle();
          return false;
        }
        return board.cycle() - still_since >= secondsToCycles(quiet_s);
      },
      secondsToCycles(budget_s));
  const std::string& out = board.output();
  if (out.find(con.prompt(), mark) != std::string::npos) return Answer::kPrompt;
  const bool rows_only = out.find_first_not_of(kRowChars, mark) == std::string::npos;
  if (settled && rows_only && out.find('\n', mark) != std::string::npos) return Answer::kEchoOnly;
  return Answer::kNone;
}

void drainConsole(Console& con, double quiet_s) {
  Board& board = con.board();
  board.runUntil([&] { return board.pendingInput() == 0; }, secondsToCycles(120));
  // A line end that reaches the firmware while its receive ring is still full (it was busy
  // with a long reply, e.g. `eeprom dump`) is lost with the other bytes, and the firmware
  // rightly keeps discarding to the next line end. So: an empty line, until one is answered by
  // a prompt and no error.
  // Output quiet first: echoing a flood can leave seconds of output queued behind the input,
  // and a prompt in it is not the answer to the empty line. Rows of read_run's `stream on`
  // (digits, '.', ',', '-') do not count as output here: they never stop.
  auto wait_quiet = [&] {
    const double t_end = board.timeS() + 120.0;
    for (;;) {
      const std::size_t seen = board.output().size();
      board.runFor(quiet_s);
      const std::string fresh = board.output().substr(seen);
      if (fresh.find_first_not_of(kRowChars) == std::string::npos) return;
      if (board.timeS() >= t_end) return;
    }
  };
  int echoed = 0;
  for (int attempt = 0; attempt < 5; ++attempt) {
    wait_quiet();
    while (con.unconsumed().find(con.prompt()) != std::string::npos) con.waitPrompt(0.01);
    const std::size_t mark = board.output().size();
    con.send("");
    const Answer answer = waitAnswer(con, mark, quiet_s, 2.0);
    // The echo alone (read_run): twice in a row, so no line end before was lost in a full ring.
    if (answer == Answer::kEchoOnly) {
      if (++echoed == 2) break;
      continue;
    }
    echoed = 0;
    if (answer == Answer::kNone) continue;  // the line end was lost: no answer at all
    bool error = false;
    for (const auto& l : con.waitPrompt(0.01)) error = error || l.rfind("error:", 0) == 0;
    if (!error) break;
  }
  board.runFor(0.05);
  while (con.unconsumed().find(con.prompt()) != std::string::npos) con.waitPrompt(0.01);
}

PulseLog::PulseLog(Board& board) {
  board.addPulseListener([this](int ch, double w, double t) { pulses_.push_back({ch, w, t}); });
}

double PulseLog::lastWiderThan(double width_us) const {
  double t = -1;
  for (const Pulse& p : pulses_)
    if (p.width_us > width_us && p.end_s > t) t = p.end_s;
  return t;
}

double PulseLog::widestBetween(double from_s, double to_s, int channel) const {
  double w = 0;
  for (const Pulse& p : pulses_)
    if (p.end_s >= from_s && p.end_s < to_s && (channel < 0 || p.channel == channel) && p.width_us > w)
      w = p.width_us;
  return w;
}

int PulseLog::countBetween(double from_s, double to_s) const {
  int n = 0;
  for (const Pulse& p : pulses_) n += (p.end_s >= from_s && p.end_s < to_s) ? 1 : 0;
  return n;
}

}  // namespace sim

// RC input on a board: see sim/rc_input.hpp.
#include "sim/rc_input.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "sim/pin_names.hpp"
#include "sim/pty_bridge.hpp"

extern "C" {
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
}

namespace sim {
namespace {

constexpr double kPtyPollS = 0.005;
constexpr std::size_t kPtyLineCap = 200;

const char* const kCommandHelp =
    "commands: ch V1 [V2 ... V8] (channels 1..N in us, 500..2500, from the next frame) | loss (no "
    "signal from the next frame) | status | help";

std::string valuesText(const std::array<double, kRcChannels>& us, int count) {
  std::string s;
  for (int i = 0; i < count; ++i) s += fmt::format("{}{:g}", i ? " " : "", us[i]);
  return s;
}

// "ch 1500 1500 1000 1500" / "ch 1500,1500": the values, or a reason in `error`.
bool parseChannels(const std::string& args, RcScriptRow& row, std::string& error) {
  std::string t = args;
  std::replace(t.begin(), t.end(), ',', ' ');
  std::istringstream in(t);
  std::string word;
  while (in >> word) {
    if (row.count == kRcChannels) {
      error = fmt::format("more than {} values", kRcChannels);
      return false;
    }
    double v = 0;
    const auto r = std::from_chars(word.data(), word.data() + word.size(), v);
    if (r.ec != std::errc() || r.ptr != word.data() + word.size() || !std::isfinite(v)) {
      error = fmt::format("'{}' is not a number of microseconds", word);
      return false;
    }
    if (v < kRcChannelMinUs || v > kRcChannelMaxUs) {
      error = fmt::format("ch{} {} us is outside {:.0f}..{:.0f} us", row.count + 1, word, kRcChannelMinUs,
                          kRcChannelMaxUs);
      return false;
    }
    row.us[row.count++] = v;
  }
  if (row.count == 0) error = "no values";
  return row.count > 0;
}

}  // namespace

RcOnBoard::RcOnBoard(Board& board, const RcSpec& spec) : board_(board), spec_(spec) {
  rc_receiver_init(board_.avr(), part_, spec_.signal, static_cast<int>(spec_.pins.size()));
  rc_receiver_connect(part_, board_.ports(), spec_.pins);
  std::weak_ptr<int> alive = alive_;
  board_.addResetListener([this, alive](uint64_t) {
    if (alive.expired()) return;
    rc_receiver_rearm(part_);  // the AVR's reset cancelled every cycle timer
    armRows();
    if (pty_master_ >= 0)
      avr_cycle_timer_register(board_.avr(), secondsToCycles(kPtyPollS), &RcOnBoard::onPtyPoll, this);
  });
}

RcOnBoard::~RcOnBoard() {
  avr_cycle_timer_cancel(board_.avr(), &RcOnBoard::onRowTime, this);
  avr_cycle_timer_cancel(board_.avr(), &RcOnBoard::onPtyPoll, this);
  if (pty_slave_ >= 0) ::close(pty_slave_);
  if (pty_master_ >= 0) ::close(pty_master_);
}

std::string RcOnBoard::describe() const {
  std::string pins;
  for (const hal::MegaPin& p : spec_.pins) pins += (pins.empty() ? "" : ", ") + megaPinName(p);
  return fmt::format("{} on {}", spec_.signal == RcSignal::kPpm ? "PPM" : "PWM", pins);
}

// --- the script ---

void RcOnBoard::play(std::vector<RcScriptRow> rows) {
  rows_ = std::move(rows);
  next_row_ = 0;
  armRows();
}

void RcOnBoard::armRows() {
  avr_cycle_timer_cancel(board_.avr(), &RcOnBoard::onRowTime, this);
  if (next_row_ >= rows_.size()) return;
  const uint64_t at = secondsToCycles(rows_[next_row_].t_s), now = board_.cycle();
  avr_cycle_timer_register(board_.avr(), at > now ? at - now : 1, &RcOnBoard::onRowTime, this);
}

uint64_t RcOnBoard::onRowTime(avr_t*, uint64_t when, void* param) {
  auto* self = static_cast<RcOnBoard*>(param);
  while (self->next_row_ < self->rows_.size() && secondsToCycles(self->rows_[self->next_row_].t_s) <= when)
    self->apply(self->rows_[self->next_row_++], "script");
  return self->next_row_ < self->rows_.size() ? secondsToCycles(self->rows_[self->next_row_].t_s) : 0;
}

void RcOnBoard::apply(const RcScriptRow& row, const char* from) {
  if (row.loss)
    rc_receiver_loss(part_);
  else
    rc_receiver_set(part_, row.us.data(), row.count);
  const std::string what = row.loss ? "loss" : "ch " + valuesText(row.us, row.count);
  const std::string where = row.line > 0 ? fmt::format(" ({} line {})", from, row.line) : fmt::format(" ({})", from);
  applied_.push_back(fmt::format("t={:.4f} s {}{}", board_.timeS(), what, where));
}

// --- live commands ---

std::string RcOnBoard::status() const {
  const RcFrame& f = part_.next;
  const int shown = spec_.signal == RcSignal::kPpm ? kRcChannels : part_.lines;
  return fmt::format("rc: t={:.4f} s, {}, {}, ch {}, {} frames sent", board_.timeS(), describe(),
                     f.on ? "signal on" : "no signal", valuesText(f.us, shown), part_.frames);
}

std::string RcOnBoard::command(const std::string& line) {
  std::string t = line;
  while (!t.empty() && std::isspace(static_cast<unsigned char>(t.back()))) t.pop_back();
  std::size_t start = 0;
  while (start < t.size() && std::isspace(static_cast<unsigned char>(t[start]))) ++start;
  t = t.substr(start);
  const std::string verb = t.substr(0, t.find(' '));
  if (verb == "help" || verb == "?") return kCommandHelp;
  if (verb == "status") return status();
  if (verb == "loss" && t == "loss") {
    apply(RcScriptRow{0.0, true, 0, {}, 0}, "pty");
    return fmt::format("ok t={:.4f} s: no signal from the next frame", board_.timeS());
  }
  if (verb == "ch") {
    RcScriptRow row;
    std::string error;
    if (!parseChannels(t.substr(2), row, error)) return fmt::format("error: {}; {}", error, kCommandHelp);
    apply(row, "pty");
    return fmt::format("ok t={:.4f} s: ch {} from the next frame", board_.timeS(), valuesText(row.us, row.count));
  }
  return fmt::format("error: '{}' is not a command; {}", t, kCommandHelp);
}

// --- the pty ---

std::string RcOnBoard::openPty() {
  if (pty_master_ >= 0) return pty_path_;
  const RawPty pty = openRawPty();
  pty_master_ = pty.master_fd;
  pty_slave_ = pty.slave_fd;
  pty_path_ = pty.path;
  avr_cycle_timer_register(board_.avr(), secondsToCycles(kPtyPollS), &RcOnBoard::onPtyPoll, this);
  return pty_path_;
}

uint64_t RcOnBoard::onPtyPoll(avr_t*, uint64_t when, void* param) {
  static_cast<RcOnBoard*>(param)->readPty();
  return when + secondsToCycles(kPtyPollS);
}

void RcOnBoard::readPty() {
  char buf[256];
  for (;;) {
    const ssize_t n = ::read(pty_master_, buf, sizeof buf);
    if (n <= 0) return;  // EAGAIN: nothing typed
    std::string out;     // the echo, as a console's, and the replies
    for (ssize_t i = 0; i < n; ++i) {
      const char c = buf[i];
      if (c == '\b' || c == 0x7F) {
        if (!pty_line_.empty()) {
          pty_line_.pop_back();
          out += "\b \b";
        }
      } else if (c != '\r' && c != '\n') {
        if (pty_line_.size() < kPtyLineCap && std::isprint(static_cast<unsigned char>(c))) {
          pty_line_ += c;
          out += c;
        }
      } else if (!pty_line_.empty()) {  // CR LF, or an empty line: nothing to do
        out += "\r\n" + command(pty_line_) + "\r\n";
        pty_line_.clear();
      }
    }
    // Nobody reading: what does not fit in the pty's buffer is dropped.
    if (!out.empty() && ::write(pty_master_, out.data(), out.size()) < 0 && errno != EAGAIN) return;
  }
}

}  // namespace sim

#include "board/console_client.hpp"
#include "elapsed.hpp"

#include <algorithm>

#include <atomic>
#include <chrono>
#include <csignal>

#include <fmt/format.h>

namespace board {
namespace {

using Clock = std::chrono::steady_clock;

std::atomic<bool> g_interrupt{false};
extern "C" void onInterrupt(int) { g_interrupt = true; }

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

constexpr std::size_t kHistory = 40;

}  // namespace

void installInterruptHandler() {
  struct sigaction sa {};
  sa.sa_handler = onInterrupt;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a blocking poll returns at once
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
}
bool interruptRequested() { return g_interrupt.load(); }
void clearInterrupt() { g_interrupt = false; }

const char* imageName(Image image) {
  switch (image) {
    case Image::kGatherStore: return "gather_store";
    case Image::kReadRun: return "read_run";
    case Image::kFly: return "fly";
    default: return "an unknown image";
  }
}

std::string checksumHex(const std::string& line) {
  unsigned x = 0;
  for (unsigned char c : line) x ^= c;
  return fmt::format("{:02X}", x & 0xFF);
}

std::string withChecksum(const std::string& line) { return line + "*" + checksumHex(line); }

ConsoleClient::ConsoleClient(SerialPort& port) : port_(port) {}

void ConsoleClient::remember(const std::string& line) {
  history_.push_back(line);
  if (history_.size() > kHistory) history_.erase(history_.begin());
}

std::string ConsoleClient::tail(std::size_t n) const {
  std::string out;
  const std::size_t from = history_.size() > n ? history_.size() - n : 0;
  for (std::size_t i = from; i < history_.size(); ++i) out += "  | " + history_[i] + "\n";
  if (!buffer_.empty()) out += "  | " + buffer_ + "\n";
  return out.empty() ? std::string("  (nothing)\n") : out;
}

bool ConsoleClient::pumpOnce(double timeout_s) {
  std::string got = port_.read(timeout_s);
  if (got.empty()) return false;
  for (char c : got)
    if (c != '\0') buffer_.push_back(c);
  return true;
}

std::string ConsoleClient::takeLine() {
  const std::size_t nl = buffer_.find('\n');
  if (nl == std::string::npos) return std::string("\x01");  // none
  std::string line = buffer_.substr(0, nl);
  buffer_.erase(0, nl + 1);
  while (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

// The prompt at the start of the unfinished line. While read_run streams, the next CSV row can
// follow the prompt on the same line ("rr> 30.468,1000,..."): the prompt still ends the answer.
bool ConsoleClient::promptPending() const { return startsWithPrompt(buffer_); }

bool ConsoleClient::startsWithPrompt(const std::string& text) const {
  return !prompt_.empty() && text.compare(0, prompt_.size(), prompt_) == 0;
}

std::vector<std::string> ConsoleClient::waitForBoot(double timeout_s) {
  std::vector<std::string> lines;
  const auto t0 = Clock::now();
  for (;;) {
    for (std::string l = takeLine(); l != "\x01"; l = takeLine()) {
      remember(l);
      lines.push_back(l);
    }
    for (const char* p : {"gs> ", "rr> ", "fly> "}) {
      if (buffer_ == p) {
        prompt_ = p;
        image_ = prompt_ == "gs> " ? Image::kGatherStore : prompt_ == "rr> " ? Image::kReadRun : Image::kFly;
        buffer_.clear();
        return lines;
      }
    }
    if (interruptRequested()) throw Interrupted("interrupted while waiting for the board to boot");
    if (secondsSince(t0) > timeout_s)
      throw BoardTimeout(fmt::format(
          "{}: no prompt (gs>, rr> or fly>) within {:.0f} s of the reset; the board is not running "
          "gather_store, read_run or fly (flash one: thrustcal board flash --port {} "
          "build/avr/firmware/gather_store/gather_store.hex), or this is not the board's port. "
          "Received:\n{}",
          port_.path(), timeout_s, port_.path(), tail()));
    pumpOnce(0.05);
  }
}

bool ConsoleClient::enableStrict() {
  checksums_ = true;  // `strict on*HH`: a firmware with checksums accepts it either way
  std::vector<std::string> lines;
  try {
    lines = command("strict on", CommandLimits{5.0, 0, false});
  } catch (...) {
    checksums_ = false;
    throw;
  }
  bool refused = false;
  for (const auto& l : lines)
    if (l.starts_with("error: ")) refused = true;
  checksums_ = !refused;
  return checksums_;
}

std::vector<std::string> ConsoleClient::command(const std::string& line, const CommandLimits& limits,
                                                const LineFn& on_line) {
  const std::string sent = checksums_ ? withChecksum(line) : line;
  buffer_.clear();
  port_.write(sent + "\r");
  std::vector<std::string> lines;
  bool first = true;
  const auto t0 = Clock::now();
  auto last = t0;
  auto last_keep_alive = t0;
  bool keeping_alive = limits.keep_alive_s > 0;
  auto fail = [&](auto&& make) {
    if (limits.abort_on_failure) abort();
    throw make();
  };
  for (;;) {
    for (std::string l = takeLine(); l != "\x01"; l = takeLine()) {
      last = Clock::now();
      if (first) {
        first = false;
        if (l == sent || endsWith(l, sent)) continue;  // the echo of what we typed
      }
      if (startsWithPrompt(l)) {  // the prompt, and a streamed row after it on its line
        remember(l);
        buffer_.clear();
        return lines;
      }
      remember(l);
      lines.push_back(l);
      if (keeping_alive && !limits.keep_alive_until.empty() && l.starts_with(limits.keep_alive_until))
        keeping_alive = false;
      if (on_line) on_line(l);
    }
    if (promptPending()) {
      buffer_.clear();
      return lines;
    }
    if (interruptRequested())
      fail([&] { return Interrupted(fmt::format("interrupted during \"{}\"{}", line,
                                                limits.abort_on_failure ? "; the abort key was sent" : "")); });
    const double waited = secondsSince(t0), quiet = std::chrono::duration<double>(Clock::now() - last).count();
    if (waited > limits.total_s || (limits.silence_s > 0 && quiet > limits.silence_s))
      fail([&] {
        return BoardTimeout(fmt::format(
            "{}: \"{}\" got no prompt within {:.0f} s{}{}; last lines:\n{}", port_.path(), line,
            waited > limits.total_s ? limits.total_s : quiet,
            waited > limits.total_s ? "" : " of silence",
            limits.abort_on_failure ? " (abort key sent)" : "", tail()));
      });
    if (keeping_alive && std::chrono::duration<double>(Clock::now() - last_keep_alive).count() >= limits.keep_alive_s) {
      port_.write("\r");
      last_keep_alive = Clock::now();
    }
    try {
      pumpOnce(keeping_alive ? std::min(0.1, limits.keep_alive_s / 2) : 0.1);
    } catch (const PortError&) {
      throw;  // nothing can be sent any more
    }
  }
}

std::vector<std::string> ConsoleClient::mustCommand(const std::string& line,
                                                    const CommandLimits& limits,
                                                    const LineFn& on_line) {
  auto lines = command(line, limits, on_line);
  for (const auto& l : lines)
    if (l.starts_with("error: "))
      throw CommandRefused(fmt::format("{} ({}) refused \"{}\": {}", port_.path(),
                                       imageName(image_), line, l));
  return lines;
}

std::string ConsoleClient::sendUntil(const std::string& line, const std::string& until,
                                     double timeout_s) {
  const std::string sent = checksums_ ? withChecksum(line) : line;
  buffer_.clear();
  port_.write(sent + "\r");
  const auto t0 = Clock::now();
  for (;;) {
    for (std::string l = takeLine(); l != "\x01"; l = takeLine()) {
      remember(l);
      if (l.starts_with(until)) return l;
      if (l.starts_with("error: "))
        throw CommandRefused(fmt::format("{} ({}) refused \"{}\": {}", port_.path(),
                                         imageName(image_), line, l));
    }
    if (interruptRequested()) throw Interrupted(fmt::format("interrupted during \"{}\"", line));
    if (secondsSince(t0) > timeout_s)
      throw BoardTimeout(fmt::format("{}: \"{}\" did not answer with \"{}...\" within {:.0f} s; "
                                     "last lines:\n{}",
                                     port_.path(), line, until, timeout_s, tail()));
    pumpOnce(0.1);
  }
}

void ConsoleClient::readLines(double timeout_s, const LineFn& on_line, bool stop_at_prompt) {
  const auto t0 = Clock::now();
  for (;;) {
    for (std::string l = takeLine(); l != "\x01"; l = takeLine()) {
      remember(l);
      if (on_line) on_line(l);
    }
    if (stop_at_prompt && promptPending()) {
      buffer_.clear();
      return;
    }
    if (secondsSince(t0) > timeout_s) return;
    pumpOnce(std::min(0.1, timeout_s));
  }
}

void ConsoleClient::abort() {
  try {
    port_.write("\r");
    const auto t0 = Clock::now();
    while (secondsSince(t0) < 3.0) {
      for (std::string l = takeLine(); l != "\x01"; l = takeLine()) remember(l);
      if (promptPending()) break;
      pumpOnce(0.1);
    }
    // One empty line: ends anything a firmware discards after an abort key; an image that
    // answers empty lines with a prompt does so now, and it is drained here.
    port_.write("\r");
    readLines(0.3, {}, false);
    buffer_.clear();
  } catch (...) {
  }
}

}  // namespace board

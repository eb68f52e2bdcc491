#include "board/liftoff.hpp"
#include "thrustcal/record_limits.hpp"

#include <cctype>
#include <chrono>

#include <fmt/format.h>

namespace board {
namespace {

// A stream row: 6 comma-separated numbers.
bool isStreamRow(const std::string& l) {
  int commas = 0;
  for (char c : l) {
    if (c == ',') {
      ++commas;
    } else if (!std::isdigit(static_cast<unsigned char>(c)) && c != '.' && c != '-') {
      return false;
    }
  }
  return commas == 5 && !l.empty() && std::isdigit(static_cast<unsigned char>(l[0]));
}

}  // namespace

std::string LiftoffLog::csv(const std::string& first_comment) const {
  std::string out = "# " + first_comment + "\n";
  for (const auto& b : boot) out += "# " + b + "\n";
  out += (header.empty() ? std::string("t_s,motor0_pwm_us,motor1_pwm_us,motor2_pwm_us,motor3_pwm_us,vbat_v") : header) + "\n";
  for (const auto& r : rows) out += r + "\n";
  for (const auto& i : info) out += i + "\n";
  if (garbled > 0) out += fmt::format("# {} garbled line(s) dropped\n", garbled);
  return out;
}

LiftoffLog flyLiftoff(ConsoleClient& con, const LiftoffOptions& o,
                      const std::function<bool(const std::string&)>& confirm,
                      const std::function<void(const std::string&)>& on_line) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  LiftoffLog log;
  if (con.image() != Image::kReadRun)
    throw std::runtime_error(fmt::format(
        "{} runs {}, not read_run; flash it first: thrustcal board flash --port {} "
        "build/avr/firmware/read_run/read_run.hex",
        con.port().path(), imageName(con.image()), con.port().path()));
  if (o.force_g < 1 || o.force_g > tc::kRecordMaxForceG)
    throw std::invalid_argument(fmt::format("--force {}: read_run takes 1..{} g per motor", o.force_g,
                                            tc::kRecordMaxForceG));
  if (o.strict) log.checksums = con.enableStrict();
  const std::string what = fmt::format(
      "all four propellers spin up to {} g each ({} ms ramp, {} ms hold); the frame must be "
      "tied down",
      o.force_g, o.ramp_ms, o.hold_ms);
  if (!confirm(what)) throw std::runtime_error(fmt::format("not confirmed: {}; nothing spun", what));

  log.header = con.sendUntil("stream on", "t_s,", 5.0);
  auto take = [&](const std::string& l) {
    if (on_line) on_line(l);
    if (l.find("liftoff ") != std::string::npos && !l.starts_with("# ")) return;  // the echo
    if (isStreamRow(l)) {
      log.rows.push_back(l);
    } else if (l.starts_with("# ")) {
      log.info.push_back(l);
      if (l.starts_with("# liftoff done")) log.done = true;
    } else if (l.starts_with("error: ")) {
      log.info.push_back("# " + l);
    } else if (!l.empty()) {
      ++log.garbled;
    }
  };
  const double expected_s = (o.ramp_ms + o.hold_ms) / 1000.0;
  std::vector<std::string> lines;
  try {
    // read_run stops a lift-off after 500 ms without a line end: an empty line every 200 ms
    // keeps it going until it reports its end.
    CommandLimits limits{expected_s * 1.5 + 10.0, 3.0, true};
    limits.keep_alive_s = 0.2;
    limits.keep_alive_until = "# liftoff ";
    lines = con.command(fmt::format("liftoff {} {} {}", o.force_g, o.ramp_ms, o.hold_ms), limits,
                        take);
    // A keep-alive that crossed the end on the wire gets a prompt of its own: read past it (the
    // rows streamed meanwhile are kept) so that `stream off` below reads its own answer.
    con.readLines(0.3, take, false);
  } catch (const PortError& e) {
    if (abortOnReturningPort(con.port().path(), 3.0))
      throw PortError(fmt::format("{}\nThe port came back: opening it reset the board and the "
                                  "abort key went out, so the motors are stopped.",
                                  e.what()));
    throw PortError(fmt::format("{}\nThe lift-off may still be running: read_run ends it after "
                                "its hold ({} ms ramp + {} ms hold). Cut the motors' power.",
                                e.what(), o.ramp_ms, o.hold_ms));
  }
  for (const auto& l : lines)
    if (l.starts_with("error: ")) {
      con.command("stream off", CommandLimits{5.0});
      throw CommandRefused(fmt::format("read_run refused the lift-off: {}", l));
    }
  con.command("stream off", CommandLimits{5.0}, take);
  log.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!log.done)
    throw std::runtime_error(fmt::format("the lift-off did not end with \"# liftoff done\"; last "
                                         "lines:\n{}",
                                         con.tail()));
  return log;
}

}  // namespace board

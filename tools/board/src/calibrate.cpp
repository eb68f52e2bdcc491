#include "board/calibrate.hpp"
#include "elapsed.hpp"

#include <cctype>
#include <chrono>
#include <cstdio>

#include <fmt/format.h>

#include "hal/board.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/sweep_limits.hpp"

namespace board {
namespace {

using Clock = std::chrono::steady_clock;
// Time limits a real board needs for a sweep: each step settles, then reads the cell (median
// of 201) and the battery (median of 101), then prints its row; 2 s arming before it.
CommandLimits sweepLimits(const CalibrateOptions& o) {
  const int steps = (o.pwm_max_us - o.pwm_min_us) / o.step_us + 1;
  const double per_step_s = o.settle_ms / 1000.0 + 0.15;
  return CommandLimits{1.5 * steps * per_step_s + 30.0, o.settle_ms / 1000.0 * 2 + 10.0, true};
}

void checkOptions(const CalibrateOptions& o) {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (o.slot < 0 || o.slot >= tc::kMotorSlots)
    bad(fmt::format("--slot {} is not a motor slot (0..{})", o.slot, tc::kMotorSlots - 1));
  if (o.mount_g < 1 || o.mount_g > tc::kKnownWeightMaxG)
    bad(fmt::format("--mount-g {} is outside 1..{} g (motor + propeller + mount on the plate)",
                    o.mount_g, tc::kKnownWeightMaxG));
  if (o.model != "v1" && o.model != "v2") bad(fmt::format("--model {}: use v1 or v2", o.model));
  if (o.pwm_min_us < tc::kSweepPwmLowestUs || o.pwm_max_us > tc::kSweepPwmHighestUs ||
      o.pwm_min_us >= o.pwm_max_us)
    bad(fmt::format("--range {} {}: need {} <= MIN < MAX <= {} us", o.pwm_min_us, o.pwm_max_us,
                    tc::kSweepPwmLowestUs, tc::kSweepPwmHighestUs));
  if (o.step_us < tc::kSweepStepMinUs || o.step_us > tc::kSweepStepMaxUs)
    bad(fmt::format("--step {}: need {}..{} us", o.step_us, tc::kSweepStepMinUs,
                    tc::kSweepStepMaxUs));
  if (o.settle_ms < tc::kSweepSettleMinMs || o.settle_ms > tc::kSweepSettleMaxMs)
    bad(fmt::format("--settle {}: need {}..{} ms", o.settle_ms, tc::kSweepSettleMinMs,
                    tc::kSweepSettleMaxMs));
}

}  // namespace

std::string escPinName(int slot) {
  const hal::EscPin& pin = hal::kEscPins[slot];
  return fmt::format("D{} (P{}{}, OC{}{})", pin.arduino_pin, pin.port, pin.bit, pin.timer,
                     pin.compare);
}

std::string SweepLog::csv(const std::string& first_comment) const {
  std::string out = "# " + first_comment + "\n";
  bool header_written = false;
  for (const auto& l : lines) {
    if (l == header) {
      out += l + "\n";
      header_written = true;
    } else if (l.starts_with("# ")) {
      out += l + "\n";
    } else if (!l.empty() && std::isdigit(static_cast<unsigned char>(l[0]))) {
      out += l + "\n";
    } else if (!l.empty()) {
      out += "# " + l + "\n";  // warnings and the like, kept as comments
    }
  }
  if (!header_written && !rows.empty()) out = "pwm_us,force_g,vbat_v,t_s,motor,dir\n" + out;
  return out;
}

namespace {

SweepLog runSweep(ConsoleClient& con, const CalibrateOptions& o, Operator& op, int sweep_no) {
  SweepLog log;
  const int planned = (o.pwm_max_us - o.pwm_min_us) / o.step_us + 1;
  const auto t0 = Clock::now();
  auto on_line = [&](const std::string& l) {
    log.lines.push_back(l);
    if (l.starts_with("pwm_us,")) {
      log.header = l;
      return;
    }
    if (l.starts_with("# ")) {
      std::sscanf(l.c_str(), "# max force %lf g", &log.max_force_g);
      if (l.starts_with("# done")) log.done = true;
      op.note(l);
      return;
    }
    if (l.starts_with("warning: ") || l.starts_with("error: ")) {
      op.note(l);
      return;
    }
    if (!l.empty() && std::isdigit(static_cast<unsigned char>(l[0])) && !log.header.empty()) {
      log.rows.push_back(l);
      SweepProgress p;
      p.sweep = sweep_no;
      std::sscanf(l.c_str(), "%d,%lf", &p.pwm_us, &p.force_g);
      p.rows = static_cast<int>(log.rows.size());
      p.rows_total = planned;
      const double per_row = secondsSince(t0) / p.rows;
      p.eta_s = per_row * (planned - p.rows);
      op.progress(p);
    }
  };
  op.sweepStarting(sweep_no);
  try {
    con.command("sweep", sweepLimits(o), on_line);
  } catch (const PortError& e) {
    if (abortOnReturningPort(con.port().path(), 3.0))
      throw PortError(fmt::format("{}\nThe port came back: opening it reset the board and the "
                                  "abort key went out, so the motor is stopped. Nothing was stored.",
                                  e.what()));
    throw PortError(fmt::format(
        "{}\nThe sweep on motor {} may still be running on the board: gather_store goes on to "
        "{} us unless a key arrives. Cut the motor's power (or press the board's reset button).",
        e.what(), o.slot, o.pwm_max_us));
  }
  log.wall_s = secondsSince(t0);
  op.sweepEnded(sweep_no, log);
  for (const auto& l : log.lines) {
    if (l.starts_with("error: "))
      throw CommandRefused(fmt::format("gather_store refused the sweep: {}", l));
    if (l.starts_with("# aborted"))
      throw std::runtime_error(fmt::format("sweep {} on motor {} was aborted by the board: {}",
                                           sweep_no, o.slot, l.substr(2)));
  }
  if (!log.done || log.rows.empty())
    throw std::runtime_error(fmt::format(
        "sweep {} on motor {} ended without its \"# done\" line ({} rows came); last lines:\n{}",
        sweep_no, o.slot, log.rows.size(), con.tail()));
  return log;
}

}  // namespace

CalibrateResult calibrate(ConsoleClient& con, const CalibrateOptions& o, Operator& op) {
  checkOptions(o);
  const auto t0 = Clock::now();
  CalibrateResult r;
  if (con.image() != Image::kGatherStore)
    throw std::runtime_error(fmt::format(
        "{} runs {}, not gather_store; flash it first: thrustcal board flash --port {} "
        "build/avr/firmware/gather_store/gather_store.hex",
        con.port().path(), imageName(con.image()), con.port().path()));
  if (o.strict) {
    r.checksums = con.enableStrict();
    op.note(r.checksums ? "console: strict mode, every line checksummed (*HH)"
                        : "console: this gather_store has no strict mode; plain lines");
  }
  const CommandLimits quick{10.0};
  con.mustCommand(fmt::format("motor {}", o.slot), quick);
  con.mustCommand(fmt::format("plate {}", o.plate_g), quick);
  con.mustCommand(fmt::format("range {} {}", o.pwm_min_us, o.pwm_max_us), quick);
  con.mustCommand(fmt::format("step {}", o.step_us), quick);
  con.mustCommand(fmt::format("settle {}", o.settle_ms), quick);
  if (o.settle_auto) con.mustCommand("settle auto", quick);
  r.cal = con.mustCommand(fmt::format("cal {}", o.mount_g), CommandLimits{20.0});
  for (const auto& l : r.cal) op.note(l);

  auto store = [&](int curve_no) {
    const std::string cmd = o.model == "v2" ? std::string("store v2") : fmt::format("store {}", curve_no);
    const auto lines = con.mustCommand(cmd, CommandLimits{30.0});
    for (const auto& l : lines) op.note(l);
    r.store.insert(r.store.end(), lines.begin(), lines.end());
  };
  auto ask = [&](int sweep_no) {
    const std::string what = fmt::format(
        "sweep {}: the propeller on motor {} (ESC on {}) spins from {} to {} us", sweep_no, o.slot,
        escPinName(o.slot), o.pwm_min_us, o.pwm_max_us);
    if (!op.confirmSpin(what))
      throw std::runtime_error(fmt::format("not confirmed: {}; nothing spun{}", what,
                                           sweep_no == 1 ? ", nothing stored" : ""));
  };

  ask(1);
  r.sweeps.push_back(runSweep(con, o, op, 1));
  store(1);
  if (o.second_sweep) {
    op.prepareSecondSweep(fmt::format(
        "connect the second supply (another voltage{}), wait until the propeller stands still",
        o.model == "v2" ? ", at least 0.5 V from the first" : ""));
    con.mustCommand("tare", CommandLimits{20.0});
    ask(2);
    r.sweeps.push_back(runSweep(con, o, op, 2));
    store(2);
  }
  r.show = con.mustCommand("show", CommandLimits{10.0});
  r.wall_s = secondsSince(t0);
  return r;
}

}  // namespace board

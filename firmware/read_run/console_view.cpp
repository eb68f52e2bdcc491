// read_run's console view (console_view.hpp): what the image prints, nothing it decides.
#include "console_view.hpp"

#include "dyn_console.hpp"
#include "slot_report.hpp"

namespace rr {
namespace view {

namespace {

using fw::say;
using fw::sayCopy;
using fw::sayLine;
using fw::sayVolts;

void sayMs(uint16_t ms) {
  fw::printUint(ms);
  say(TC_FLASH_TEXT(" ms"));
}

}  // namespace

void banner() {
  fw::newline();
  sayLine(TC_FLASH_TEXT("read_run: force commands in grams -> ESC pulses (thrustcal, thesis Read and Run)"));
  fw::printResetCause();
  say(TC_FLASH_TEXT("type help for commands; while motors run send a line at least every "));
  sayMs(kFailsafeMs);
  fw::newline();
}

void refuseMotor(uint8_t index, const Motor& m) {
  fw::motorLine(TC_FLASH_TEXT("error: "), index, m, TC_FLASH_TEXT(" is "),
            TC_FLASH_TEXT("; it stays at 1000 us - recalibrate it with gather_store"));
}

void heldMotor(uint8_t index, const Motor& m) {
  fw::motorLine(TC_FLASH_TEXT("warning: "), index, m, TC_FLASH_TEXT(" "), TC_FLASH_TEXT("; held at 1000 us"));
}

void liftoffNeedsAll(uint8_t index, const Motor& m) {
  fw::motorLine(TC_FLASH_TEXT("error: liftoff needs all four motors calibrated; "), index, m,
            TC_FLASH_TEXT(" is "), TC_FLASH_TEXT("; recalibrate it with gather_store"));
}

void liftoffStarted(uint16_t force_g, uint16_t ramp_ms, uint16_t hold_ms) {
  say(TC_FLASH_TEXT("# liftoff: ramp 0 -> "));
  fw::printUint(force_g);
  say(TC_FLASH_TEXT(" g in "));
  sayMs(ramp_ms);
  say(TC_FLASH_TEXT(", hold "));
  sayMs(hold_ms);
  say(TC_FLASH_TEXT(", then stop; empty lines keep it going (at least every "));
  sayMs(kFailsafeMs);
  sayLine(TC_FLASH_TEXT("), any other key aborts"));
}

void liftoffHold(const ReadRunApp& app) {
  say(TC_FLASH_TEXT("# hold "));
  fw::printUint(app.liftoff().forceG());
  say(TC_FLASH_TEXT(" g for "));
  sayMs(app.liftoff().holdMs());
  fw::newline();
}

void liftoffProgress(const ReadRunApp& app, uint32_t elapsed_ms, uint16_t force_g) {
  say(TC_FLASH_TEXT("# t "));
  fw::printFixed(static_cast<int32_t>(elapsed_ms), 3);
  say(app.liftoff().holding() ? TC_FLASH_TEXT(" s hold ") : TC_FLASH_TEXT(" s ramp "));
  fw::printUint(force_g);
  say(TC_FLASH_TEXT(" g, pwm"));
  for (uint8_t i = 0; i < kMotors; ++i) {
    hal::Uart::write(' ');
    fw::printUint(app.motor(i).pwm_us);
  }
  say(TC_FLASH_TEXT(" us, battery "));
  sayVolts(app.batteryMv());
  fw::newline();
}

void liftoffDone() { sayLine(TC_FLASH_TEXT("# liftoff done: motors stopped")); }

void liftoffAborted() {
  fw::newline();
  sayLine(TC_FLASH_TEXT("# liftoff aborted by input: motors stopped"));
}

void liftoffLinkLost() {
  fw::newline();
  say(TC_FLASH_TEXT("# liftoff stopped: no line end for "));
  sayMs(kFailsafeMs);
  sayLine(TC_FLASH_TEXT(" (keep it alive with empty lines; any other key aborts): motors stopped"));
}

void failsafe() {
  fw::newline();
  say(TC_FLASH_TEXT("failsafe: no command for "));
  sayMs(kFailsafeMs);
  sayLine(TC_FLASH_TEXT(", motors stopped"));
}

void status(const ReadRunApp& app, void (*yield)()) {
  for (uint8_t i = 0; i < kMotors; ++i) fw::motorStatus(app.motors(), i);
  if (app.motors().v2Motors() != 0) {
    const tc::BusVoltageFilter& bus = app.busFilter();
    say(TC_FLASH_TEXT("bus filter "));
    sayVolts(bus.mv);
    say(TC_FLASH_TEXT(" (v2 motors: 1/"));
    fw::printUint(1u << bus.shift);
    say(TC_FLASH_TEXT(" per frame), readings rejected "));
    fw::printUint(bus.rejected);
    fw::newline();
  }
  fw::dynState(app.motors());
  say(TC_FLASH_TEXT("battery "));
  sayVolts(app.batteryMv());
  say(TC_FLASH_TEXT(" raw (median of "));
  fw::printUint(tc::kBatteryWindow);
  say(TC_FLASH_TEXT("), frame rate "));
  fw::printUint(app.frameHz());
  say(TC_FLASH_TEXT(" Hz, "));
  say(app.isRunning() ? TC_FLASH_TEXT("running") : TC_FLASH_TEXT("stopped"));
  say(TC_FLASH_TEXT(", failsafe trips "));
  fw::printUint(app.failsafeTrips());
  fw::newline();
  fw::printHealth(app.console(), yield);  // frames go on during the stack scan
}

void streamHeader() {
  sayLine(TC_FLASH_TEXT("t_s,motor0_pwm_us,motor1_pwm_us,motor2_pwm_us,motor3_pwm_us,vbat_v"));
}

void streamRow(const ReadRunApp& app, uint32_t now_ms) {
  fw::printFixed(static_cast<int32_t>(now_ms), 3);
  for (uint8_t i = 0; i < kMotors; ++i) {
    hal::Uart::write(',');
    fw::printUint(app.motor(i).pwm_us);
  }
  hal::Uart::write(',');
  fw::printFixed(app.batteryMv(), 3);
  fw::newline();
}

void helpFooter() {
  say(TC_FLASH_TEXT("failsafe: while a motor runs, "));
  sayMs(kFailsafeMs);
  sayLine(TC_FLASH_TEXT(" without a line (an empty line will do;"));
  sayLine(TC_FLASH_TEXT("with strict on a checksummed one, e.g. *00) stops all motors; during liftoff"));
  sayLine(TC_FLASH_TEXT("empty lines keep it going and any other key aborts it"));
  say(TC_FLASH_TEXT("lines: CR, LF or CRLF, at most "));
  fw::printUint(fw::kLineMax);
  sayLine(TC_FLASH_TEXT(" characters; optional checksum *HH = XOR"));
  sayLine(TC_FLASH_TEXT("of the line before '*'; a damaged line is rejected whole (docs/console.md)"));
}

}  // namespace view
}  // namespace rr

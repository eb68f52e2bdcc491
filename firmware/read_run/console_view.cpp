// read_run's console view (console_view.hpp): what the image prints, nothing it decides.
#include "console_view.hpp"

namespace rr {
namespace view {

namespace {

using fw::say;
using fw::sayCopy;
using fw::sayLine;
using fw::sayVolts;

// Heaviest force both curves reach without saturating.
uint16_t reachableGrams(const tc::MotorCalibration& cal) {
  uint16_t grams = cal.first.maxGrams();
  if (cal.hasSecondCurve() && cal.second.maxGrams() < grams) grams = cal.second.maxGrams();
  return grams;
}

// Grams (floor) of a force in decigrams.
uint16_t gramsFromDg(uint16_t force_dg) { return static_cast<uint16_t>(force_dg / 10u); }

// Start-up line of a v1 slot (the thesis record), after "motor N: ok".
void sayV1Summary(const tc::MotorCalibration& cal) {
  say(TC_FLASH_TEXT(", V1 "));
  sayVolts(cal.first.start_mv);
  say(TC_FLASH_TEXT(", V2 "));
  if (cal.hasSecondCurve()) {
    sayVolts(cal.second.start_mv);
  } else {
    say(TC_FLASH_TEXT("none (single curve, no voltage compensation)"));
  }
  say(TC_FLASH_TEXT(", max "));
  fw::printUint(reachableGrams(cal));
  say(TC_FLASH_TEXT(" g, model v1 (thesis option 2.1)"));
}

// Start-up line of a v2 slot, after "motor N: ok": start threshold, the force reachable at
// the sweep's resting voltage, the refining sweep's voltage, and a damaged other copy.
void sayV2Summary(const Motor& m, const tc::ModelV2& v2, uint8_t index) {
  say(TC_FLASH_TEXT(", model v2 (effective voltage), start "));
  fw::printFixed(static_cast<int32_t>((static_cast<uint32_t>(v2.start_q4_us) * 10u + 8u) >> 4), 1);
  say(TC_FLASH_TEXT(" us, max "));
  fw::printUint(gramsFromDg(tc::headroomDg(v2, v2.rest_mv)));
  say(TC_FLASH_TEXT(" g at "));
  sayVolts(v2.rest_mv);
  if (v2.second_mv != 0) {
    say(TC_FLASH_TEXT(", refined at "));
    sayVolts(v2.second_mv);
  }
  if (tc::isSpareCopy(m.v2_copy)) {
    // A store was cut short after its copy in another slot was complete.
    say(TC_FLASH_TEXT("; flying the copy kept in motor "));
    fw::printUint(tc::spareHost(index, m.v2_copy));
    say(TC_FLASH_TEXT("'s slot (a store was cut short; the next gather_store store settles it)"));
    return;
  }
  const uint8_t other = static_cast<uint8_t>(m.v2_copy ^ 1u);
  const tc::DecodeStatus other_status = m.v2_copy_status[other];
  if (other_status != tc::DecodeStatus::kOk && other_status != tc::DecodeStatus::kErased) {
    say(TC_FLASH_TEXT("; warning: "));
    sayCopy(other);
    say(TC_FLASH_TEXT(" "));
    hal::Uart::print(tc::decodeStatusText(other_status));
    say(TC_FLASH_TEXT(", flying "));
    sayCopy(m.v2_copy);
    say(TC_FLASH_TEXT(" - recalibrate to restore the spare copy"));
  }
}

// Flags of one controller result in words, comma separated; "none" when clear.
void sayFlags(uint8_t flags) {
  if (flags == 0) {
    say(TC_FLASH_TEXT("none"));
    return;
  }
  bool first = true;
  auto word = [&](uint8_t bit, const char* text) {
    if ((flags & bit) == 0) return;
    if (!first) say(TC_FLASH_TEXT(", "));
    say(text);
    first = false;
  };
  word(tc::kStopped, TC_FLASH_TEXT("stopped"));
  word(tc::kNotCalibrated, TC_FLASH_TEXT("not calibrated"));
  word(tc::kSaturated, TC_FLASH_TEXT("saturated"));
  word(tc::kVoltageInvalid, TC_FLASH_TEXT("battery voltage invalid"));
  word(tc::kSingleCurve, TC_FLASH_TEXT("single curve"));
  word(tc::kEqualVoltages, TC_FLASH_TEXT("equal curve voltages"));
  word(tc::kClamped, TC_FLASH_TEXT("clamped"));
}

void sayMs(uint16_t ms) {
  fw::printUint(ms);
  say(TC_FLASH_TEXT(" ms"));
}

// "<prefix>motor N<middle><why it is not calibrated><suffix>" and the line end.
void motorLine(const char* prefix, uint8_t index, const Motor& m, const char* middle,
               const char* suffix) {
  say(prefix);
  sayMotor(index);
  say(middle);
  sayRecordStatus(m);
  sayLine(suffix);
}

void statusMotor(const ReadRunApp& app, uint8_t i) {
  const Motor& m = app.motor(i);
  sayMotor(i);
  say(TC_FLASH_TEXT(": "));
  if (!m.isArmable()) {
    sayRecordStatus(m);
    say(TC_FLASH_TEXT("; held at "));
    fw::printUint(m.pwm_us);
    sayLine(TC_FLASH_TEXT(" us"));
    return;
  }
  fw::printUint(m.force_g);
  say(TC_FLASH_TEXT(" g, "));
  fw::printUint(m.pwm_us);
  say(TC_FLASH_TEXT(" us, battery "));
  sayVolts(m.vbat_mv);
  if (m.fliesV2()) {
    // Headroom: the most this motor reaches at the present (filtered) voltage with the
    // ESC at its maximum pulse. One division: status only, never per frame.
    const tc::BusVoltageFilter& bus = app.busFilter();
    say(TC_FLASH_TEXT(" filtered, headroom "));
    fw::printUint(gramsFromDg(tc::headroomDg(m.model.v2(), bus.isValid() ? bus.mv
                                                                         : m.model.v2().rest_mv)));
    say(TC_FLASH_TEXT(" g, flags: "));
  } else {
    say(TC_FLASH_TEXT(" compensated, flags: "));
  }
  sayFlags(m.flags);
  fw::newline();
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

void sayMotor(uint8_t index) {
  say(TC_FLASH_TEXT("motor "));
  fw::printUint(index);
}

void sayRecordStatus(const Motor& m) {
  say(TC_FLASH_TEXT("not calibrated: "));
  if (m.layout != tc::SlotLayout::kModelV2) {
    fw::printRecordStatus(m.record, m.why);
    return;
  }
  say(TC_FLASH_TEXT("v2 record, both copies bad ("));
  for (uint8_t copy = 0; copy < 2; ++copy) {
    if (copy) say(TC_FLASH_TEXT(", "));
    sayCopy(copy);
    say(TC_FLASH_TEXT(" "));
    hal::Uart::print(tc::decodeStatusText(m.v2_copy_status[copy]));
  }
  say(TC_FLASH_TEXT(")"));
  if (m.record == tc::DecodeStatus::kBadContent && !m.why.ok()) {
    say(TC_FLASH_TEXT(": "));
    fw::printRecordStatus(m.record, m.why);
  }
}

void slotLoaded(uint8_t index, const Motor& m, const tc::ModelV2& v2,
                const tc::MotorCalibration& v1) {
  sayMotor(index);
  say(TC_FLASH_TEXT(": "));
  if (m.isArmable()) {
    say(TC_FLASH_TEXT("ok"));
    if (m.fliesV2()) {
      sayV2Summary(m, v2, index);
    } else {
      sayV1Summary(v1);
    }
  } else {
    sayRecordStatus(m);
    say(TC_FLASH_TEXT(" - refusing to arm; recalibrate it with gather_store"));
  }
  fw::newline();
}

void calibratedCount(uint8_t calibrated) {
  say(TC_FLASH_TEXT("calibrated motors: "));
  fw::printUint(calibrated);
  say(TC_FLASH_TEXT(" of "));
  fw::printUint(kMotors);
  fw::newline();
  if (calibrated == 0) {
    sayLine(TC_FLASH_TEXT("warning: no motor is calibrated; every ESC stays at 1000 us - calibrate the "
                    "motors with gather_store first"));
  }
}

void refuseMotor(uint8_t index, const Motor& m) {
  motorLine(TC_FLASH_TEXT("error: "), index, m, TC_FLASH_TEXT(" is "),
            TC_FLASH_TEXT("; it stays at 1000 us - recalibrate it with gather_store"));
}

void heldMotor(uint8_t index, const Motor& m) {
  motorLine(TC_FLASH_TEXT("warning: "), index, m, TC_FLASH_TEXT(" "), TC_FLASH_TEXT("; held at 1000 us"));
}

void liftoffNeedsAll(uint8_t index, const Motor& m) {
  motorLine(TC_FLASH_TEXT("error: liftoff needs all four motors calibrated; "), index, m,
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
  fw::printUint(app.liftoffForceG());
  say(TC_FLASH_TEXT(" g for "));
  sayMs(app.liftoffHoldMs());
  fw::newline();
}

void liftoffProgress(const ReadRunApp& app, uint32_t elapsed_ms, uint16_t force_g) {
  say(TC_FLASH_TEXT("# t "));
  fw::printFixed(static_cast<int32_t>(elapsed_ms), 3);
  say(app.liftoffHolding() ? TC_FLASH_TEXT(" s hold ") : TC_FLASH_TEXT(" s ramp "));
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
  for (uint8_t i = 0; i < kMotors; ++i) statusMotor(app, i);
  if (app.v2Motors() != 0) {
    const tc::BusVoltageFilter& bus = app.busFilter();
    say(TC_FLASH_TEXT("bus filter "));
    sayVolts(bus.mv);
    say(TC_FLASH_TEXT(" (v2 motors: 1/"));
    fw::printUint(1u << bus.shift);
    say(TC_FLASH_TEXT(" per frame), readings rejected "));
    fw::printUint(bus.rejected);
    fw::newline();
  }
  say(TC_FLASH_TEXT("battery "));
  sayVolts(app.batteryMv());
  say(TC_FLASH_TEXT(" raw (median of "));
  fw::printUint(kBatteryWindow);
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

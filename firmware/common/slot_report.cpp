// What the force API's images say about their motors (slot_report.hpp).
#include "slot_report.hpp"

#include "console.hpp"
#include "hal/hal.hpp"
#include "record_report.hpp"

namespace fw {

namespace {

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

}  // namespace

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
  fw::printUint(ForceActuators::kMotors);
  fw::newline();
  if (calibrated == 0) {
    sayLine(TC_FLASH_TEXT("warning: no motor is calibrated; every ESC stays at 1000 us - calibrate the "
                    "motors with gather_store first"));
  }
}

uint8_t loadAndReport(ForceActuators& motors) {
  motors.loadSettings();
  say(TC_FLASH_TEXT("battery monitor: "));
  printDivider(motors.boardSettings());
  newline();
  const uint8_t calibrated = motors.loadSlots(&slotLoaded);
  calibratedCount(calibrated);
  return calibrated;
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

void motorStatus(const ForceActuators& motors, uint8_t i) {
  const Motor& m = motors.motor(i);
  sayMotor(i);
  say(TC_FLASH_TEXT(": "));
  if (!m.isArmable()) {
    sayRecordStatus(m);
    say(TC_FLASH_TEXT("; held at "));
    fw::printUint(m.pwm_us);
    sayLine(TC_FLASH_TEXT(" us"));
    return;
  }
  fw::printFixed(m.force_dg, 1);
  say(TC_FLASH_TEXT(" g, "));
  fw::printUint(m.pwm_us);
  say(TC_FLASH_TEXT(" us, battery "));
  sayVolts(m.vbat_mv);
  if (m.fliesV2()) {
    // Headroom: the most this motor reaches at the present (filtered) voltage with the
    // ESC at its maximum pulse. One division: status only, never per frame.
    const tc::BusVoltageFilter& bus = motors.busFilter();
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

}  // namespace fw

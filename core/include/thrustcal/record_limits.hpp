// What a calibration record may hold and still be right: the physical limits every decoder
// (v1 thesis record, v2 model record), the firmware and the host tools (lab export) apply.
// One place, named constants; docs/eeprom.md gives each limit with its reason.
//
// The limits follow the hardware the project targets: a 50 Hz servo-PWM ESC (1000..2000 us),
// 1S..6S LiPo packs read through a resistor divider into a 5 V, 10-bit ADC, motors whose
// largest thrust lies between 5 g and 5 kg.
#pragma once
#include <stdint.h>

namespace tc {

// The ESC's throttle range (servo PWM, 50..400 Hz): kThrottleMinUs is zero throttle (motor
// off), kThrottleMaxUs full throttle. The firmware never commands a pulse outside it, so a curve
// that needs one cannot be what the motor did on the bench. (The timer driver's own clamp,
// wider, is hal::kPulseClampMinUs/MaxUs in hal/board.hpp.)
constexpr uint16_t kThrottleMinUs = 1000;
constexpr uint16_t kThrottleMaxUs = 2000;

// Battery packs, 1S..6S LiPo: 3.0 V (one cell, empty) .. 26.0 V (six cells at 4.2 V are 25.2 V;
// 0.8 V more for the divider's tolerance). Readings and stored voltages outside are a fault.
constexpr uint16_t kPackMinMv = 3000;
constexpr uint16_t kPackMaxMv = 26000;

// Largest force of a curve: 5 g (a tiny whoop motor) .. 5 kg (a large 6S motor).
constexpr uint16_t kRecordMinForceG = 5;
constexpr uint16_t kRecordMaxForceG = 5000;

// v2: the ESC start threshold (the pulse where force leaves zero, extrapolated by the fit).
// Below 900 us the motor would push at read_run's stop pulse (1000 us); an ESC that starts
// above 1500 us (half throttle) is misconfigured or the fit went wrong.
constexpr uint16_t kStartMinUs = 900;
constexpr uint16_t kStartMaxUs = 1500;
// v2: the PWM at the last knot, at the best voltage the record saw, may exceed the ESC's
// maximum by this much (rounding of the stored drive and sag units).
constexpr uint16_t kPwmToleranceUs = 5;

// Flat curves. v1: between 1 g and its heaviest gram a curve must climb at least
// kMinCurveSpanUs and at least 1 us per kMaxGramsPerUs grams (a 5 kg motor gains about
// 5 g per us on average over its range, so 10 g per us on average is steeper than any real
// motor). v2: from the first knot to the last the force at least doubles, so even for a
// thrust exponent of 3 the drive must grow by kMinDriveGrowthPct.
constexpr uint16_t kMinCurveSpanUs = 5;
constexpr uint16_t kMaxGramsPerUs = 10;
constexpr uint16_t kMinDriveGrowthPct = 25;

// Battery sag the monitor may see under load: at most half the resting voltage (more is a
// wiring or supply fault), and a reading may rise under load by at most kMaxSagRiseMv (noise).
constexpr uint8_t kMaxSagPercent = 50;
constexpr uint16_t kMaxSagRiseMv = 300;

// The thesis battery monitor: 100 kOhm over 47 kOhm into a 5 V ADC, full scale 15.638 V.
constexpr uint32_t kDefaultDividerTopOhm = 100000;
constexpr uint32_t kDefaultDividerBottomOhm = 47000;
constexpr uint16_t kDefaultFullScaleMv = 15638;
constexpr uint16_t kAdcReferenceMv = 5000;

// What the decoders need to know about the board: the monitor's full scale (the divider
// setting). Voltages in a record must lie within kPackMinMv .. min(kPackMaxMv, full scale):
// the monitor cannot have read more than its full scale.
struct RecordLimits {
  uint16_t monitor_full_scale_mv = kDefaultFullScaleMv;

  uint16_t maxMv() const {
    return monitor_full_scale_mv < kPackMaxMv ? monitor_full_scale_mv : kPackMaxMv;
  }
};

}  // namespace tc

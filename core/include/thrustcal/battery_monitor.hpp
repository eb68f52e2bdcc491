// Battery monitor: 100k/47k divider into A1 (thesis sec. 5.2, 6.1, 6.2).
//
// counts -> millivolts is the thesis's map(x, 0, 1023, 0, 15638): full scale 15.638 V at 5 V
// on the pin. Under load the reading drops below the battery's true voltage (11.35 V true,
// 10.8 V read); the sag is measured during the first sweep, averaged over 40 us PWM bins
// (13 bins) and stored as offsets; the offset for the last PWM sent is added to each reading.
#pragma once
#include <stdint.h>

#include "thrustcal/limits.hpp"

namespace tc {

constexpr uint8_t kSagBins = 13;
constexpr uint16_t kSagBinWidthUs = 40;

struct BatteryConfig {
  uint16_t full_scale_mv = 15638;  // (R1 + R2) / R2 * 5 V with R1 = 100k, R2 = 47k
  uint16_t adc_max_counts = 1023;  // thesis map() uses 1023
  uint16_t min_sane_mv = kVbatSaneMinMv;  // below: sensor fault or dead pack (limits.hpp)
  uint16_t max_sane_mv = kVbatSaneMaxMv;  // above: sensor fault or wrong divider
};

// Full scale in millivolts of a divider R1 (top) / R2 (bottom) at a 5 V ADC reference,
// rounded to nearest: 100k/47k -> 15638. r2 == 0 -> 0 (not a divider); saturates at 65535.
uint16_t dividerFullScaleMillivolts(uint32_t r1_ohm, uint32_t r2_ohm, uint16_t vref_mv = 5000);

// Sag offsets: offset_mv[i] is how much lower the monitor read in PWM bin i than in bin 0.
struct SagTable {
  uint16_t base_pwm_us = kThrottleMinUs;  // PWM at the start of bin 0
  int16_t offset_mv[kSagBins] = {};     // >= 0 normally; bin 0 is always 0

  // Bin of a PWM: (pwm - base) / 40, clamped to 0..12 (below base: bin 0).
  static uint8_t binFor(uint16_t pwm_us, uint16_t base_pwm_us);
  // Offset for a PWM, interpolated linearly between the centres of the bins (flat below the
  // centre of bin 0 and above the centre of bin 12). The thesis used the bin's offset as a
  // step; on the virtual bench a hovering motor whose PWM sat on a bin edge then toggled
  // between two offsets (a limit cycle of ~12 us every few frames), which interpolation ends.
  int16_t offsetFor(uint16_t pwm_us) const;
};

class BatteryMonitor {
 public:
  explicit BatteryMonitor(const BatteryConfig& config = BatteryConfig());
  // Thesis map(): counts * full_scale / adc_max. Counts above adc_max read as full scale.
  uint16_t millivoltsFromCounts(uint16_t counts) const;
  // The same at half-count resolution, from two readings added (0..2 * adc_max):
  // two_counts * full_scale / (2 * adc_max), truncating; above 2 * adc_max, full scale. No
  // division (read_run's every frame) when 2 * adc_max < 2048 and the full scale below
  // 1024 times it: a multiplication by a rounded-up 2^22 / (2 * adc_max), exact in that range.
  uint16_t millivoltsFromTwoCounts(uint16_t two_counts) const;
  // Reading + sag offset of the last PWM sent (thesis fig. 6.9). Saturates at 0 and 65535.
  uint16_t compensatedMillivolts(uint16_t measured_mv, uint16_t last_pwm_us,
                                 const SagTable& sag) const;
  // The same with the sag offset already looked up (a caller that keeps it while the pulse
  // stays the same): reading + offset, saturated at 0 and 65535.
  static uint16_t withSagOffset(uint16_t measured_mv, int16_t offset_mv) {
    const int32_t mv = static_cast<int32_t>(measured_mv) + offset_mv;
    if (mv < 0) return 0;
    if (mv > 0xFFFFL) return 0xFFFF;
    return static_cast<uint16_t>(mv);
  }
  bool isSane(uint16_t mv) const { return mv >= config_.min_sane_mv && mv <= config_.max_sane_mv; }
  const BatteryConfig& config() const { return config_; }

 private:
  BatteryConfig config_;
  uint32_t two_counts_factor_q22_ = 0;  // ceil(full_scale * 2^22 / (2 * adc_max)); 0: divide
};

// Collects (pwm, battery) pairs during a sweep and turns them into the start voltage and the
// 13 offsets (thesis fig. 6.9: average per 40 us bin; Average[0] is the start voltage;
// offset[i] = Average[0] - Average[i]). Bins nobody visited take the nearest visited bin's
// offset; samples below base go to bin 0; samples at or above the end of the last bin
// (base + 13 * 40 us) are left out, so bin 12 is the average of its own 40 us and not of the
// whole rest of the sweep (which made it read ~3x the sag of its neighbour).
class SagBuilder {
 public:
  void reset(uint16_t base_pwm_us);
  void add(uint16_t pwm_us, uint16_t vbat_mv);
  // False (out untouched) when bin 0 has no sample: there is no start voltage.
  bool build(SagTable& out, uint16_t& start_mv) const;
  uint16_t samples(uint8_t bin) const { return bin < kSagBins ? count_[bin] : 0; }

 private:
  uint16_t base_pwm_us_ = kThrottleMinUs;
  uint32_t sum_mv_[kSagBins] = {};
  uint16_t count_[kSagBins] = {};
};

}  // namespace tc

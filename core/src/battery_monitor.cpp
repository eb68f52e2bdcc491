// Battery monitor: thesis map() from counts to millivolts, sag offsets per 40 us PWM bin.
#include "thrustcal/battery_monitor.hpp"

namespace tc {

uint16_t dividerFullScaleMillivolts(uint32_t r1_ohm, uint32_t r2_ohm, uint16_t vref_mv) {
  if (r2_ohm == 0) return 0;  // no bottom resistor: not a divider
  // vref * (r1 + r2) / r2 = vref * q + vref * rem / r2, all in uint32. Scale both resistors
  // down (same ratio) until vref * rem cannot overflow; only megaohm dividers lose bits.
  while (r2_ohm > 0xFFFFFFFFul / (vref_mv ? vref_mv : 1u) || r1_ohm > 0xFFFFFFFFul - r2_ohm) {
    r1_ohm >>= 1;
    r2_ohm >>= 1;
  }
  const uint32_t total = r1_ohm + r2_ohm;
  const uint32_t q = total / r2_ohm;
  const uint32_t rem = total % r2_ohm;
  const uint32_t frac = (static_cast<uint32_t>(vref_mv) * rem + r2_ohm / 2) / r2_ohm;
  if (q > 0xFFFFul) return 0xFFFF;
  const uint32_t mv = static_cast<uint32_t>(vref_mv) * q + frac;
  return mv > 0xFFFFul ? static_cast<uint16_t>(0xFFFF) : static_cast<uint16_t>(mv);
}

uint8_t SagTable::binFor(uint16_t pwm_us, uint16_t base_pwm_us) {
  if (pwm_us <= base_pwm_us) return 0;
  const uint16_t bin = static_cast<uint16_t>((pwm_us - base_pwm_us) / kSagBinWidthUs);
  return bin >= kSagBins ? static_cast<uint8_t>(kSagBins - 1) : static_cast<uint8_t>(bin);
}

namespace {

// floor(x / 40) without a division (read_run and fly call offsetFor per motor and frame):
// floor(x / 8) then / 5 as a multiplication, x * 52429 / 2^18, exact for x / 8 < 2^16 (checked
// for every x by tests/core/battery_monitor_test.cpp). The product's high half is taken whole
// and shifted by 2: an AVR shifts a 32-bit value by 18 one bit at a time (~90 cycles).
uint32_t div40(uint32_t x) {
  if (x >= (1ul << 19)) return x / 40u;  // beyond the multiplication's range: divide
  const uint32_t product = static_cast<uint32_t>(static_cast<uint16_t>(x >> 3)) * 52429u;
  return static_cast<uint16_t>(product >> 16) >> 2;
}

}  // namespace

int16_t SagTable::offsetFor(uint16_t pwm_us) const {
  static_assert(kSagBinWidthUs == 40, "div40 divides by the bin width");
  const uint16_t half_bin_us = kSagBinWidthUs / 2;
  const uint16_t first_centre_us = static_cast<uint16_t>(base_pwm_us + half_bin_us);
  if (pwm_us <= first_centre_us) return offset_mv[0];
  const uint16_t from_centre_us = static_cast<uint16_t>(pwm_us - first_centre_us);
  if (from_centre_us >= (kSagBins - 1) * kSagBinWidthUs) return offset_mv[kSagBins - 1];
  const uint8_t bin = static_cast<uint8_t>(div40(from_centre_us));
  const int16_t fraction_us = static_cast<int16_t>(from_centre_us - static_cast<uint16_t>(bin * kSagBinWidthUs));
  const int16_t lo = offset_mv[bin];
  const int16_t hi = offset_mv[bin + 1];
  // |hi - lo| * 40 fits int32; rounded to the nearest mV (halves away from zero). A record's
  // offsets (-1280..1270 mV) differ by less than 2^15: one 16 x 16 product.
  const int32_t difference = static_cast<int32_t>(hi) - lo;
  const int32_t delta = difference >= -32768 && difference <= 32767
                            ? static_cast<int32_t>(static_cast<int16_t>(difference)) * fraction_us
                            : difference * fraction_us;
  const uint32_t magnitude = static_cast<uint32_t>(delta >= 0 ? delta : -delta) + kSagBinWidthUs / 2;
  const int32_t step = static_cast<int32_t>(div40(magnitude));
  return static_cast<int16_t>(lo + (delta >= 0 ? step : -step));
}

BatteryMonitor::BatteryMonitor(const BatteryConfig& config) : config_(config) {
  const uint32_t den = 2ul * config_.adc_max_counts;
  // floor(m * fs / den) == floor(m * ceil(fs * 2^22 / den) / 2^22) for every m <= den when
  // den^2 < 2^22; the factor fits 32 bits when fs < den * 1024.
  if (den == 0 || den >= 2048u || config_.full_scale_mv >= den * 1024u) return;
  // ceil(fs * 2^22 / den) by long division in steps of 11 bits (fs * 2^22 needs 38 bits).
  const uint32_t q = config_.full_scale_mv / den;
  const uint32_t t1 = (config_.full_scale_mv % den) << 11;
  const uint32_t t2 = (t1 % den) << 11;
  two_counts_factor_q22_ = (q << 22) + ((t1 / den) << 11) + t2 / den + (t2 % den != 0 ? 1u : 0u);
}

uint16_t BatteryMonitor::millivoltsFromTwoCounts(uint16_t two_counts) const {
  const uint16_t den = static_cast<uint16_t>(2u * config_.adc_max_counts);
  if (den == 0) return 0;
  if (two_counts >= den) return config_.full_scale_mv;
  if (two_counts_factor_q22_ == 0)
    return static_cast<uint16_t>(static_cast<uint32_t>(two_counts) * config_.full_scale_mv / den);
  // two_counts * factor / 2^22 with 16 x 16 products: (m * f_hi + (m * f_lo) / 2^16) / 2^6.
  const uint32_t hi = static_cast<uint32_t>(two_counts) * static_cast<uint16_t>(two_counts_factor_q22_ >> 16);
  const uint32_t lo = static_cast<uint32_t>(two_counts) * static_cast<uint16_t>(two_counts_factor_q22_);
  return static_cast<uint16_t>((hi + (lo >> 16)) >> 6);
}

uint16_t BatteryMonitor::millivoltsFromCounts(uint16_t counts) const {
  if (config_.adc_max_counts == 0) return 0;
  if (counts >= config_.adc_max_counts) return config_.full_scale_mv;
  // map(x, 0, adc_max, 0, full_scale): truncating, like Arduino's map().
  return static_cast<uint16_t>(static_cast<uint32_t>(counts) * config_.full_scale_mv /
                               config_.adc_max_counts);
}

uint16_t BatteryMonitor::compensatedMillivolts(uint16_t measured_mv, uint16_t last_pwm_us,
                                               const SagTable& sag) const {
  return withSagOffset(measured_mv, sag.offsetFor(last_pwm_us));
}

void SagBuilder::reset(uint16_t base_pwm_us) {
  base_pwm_us_ = base_pwm_us;
  for (uint8_t i = 0; i < kSagBins; ++i) {
    sum_mv_[i] = 0;
    count_[i] = 0;
  }
}

void SagBuilder::add(uint16_t pwm_us, uint16_t vbat_mv) {
  if (pwm_us >= base_pwm_us_ && pwm_us - base_pwm_us_ >= kSagBins * kSagBinWidthUs) return;
  const uint8_t bin = SagTable::binFor(pwm_us, base_pwm_us_);
  if (count_[bin] == 0xFFFF) return;  // 65535 samples per bin are plenty: the sum stays exact
  sum_mv_[bin] += vbat_mv;
  ++count_[bin];
}

bool SagBuilder::build(SagTable& out, uint16_t& start_mv) const {
  if (count_[0] == 0) return false;
  int32_t average_mv[kSagBins];
  for (uint8_t i = 0; i < kSagBins; ++i) {
    average_mv[i] = count_[i] ? static_cast<int32_t>((sum_mv_[i] + count_[i] / 2u) / count_[i]) : 0;
  }
  out.base_pwm_us = base_pwm_us_;
  for (uint8_t i = 0; i < kSagBins; ++i) {
    // Unvisited bins borrow from the nearest visited bin (the lower one on a tie). Bin 0 is
    // visited, so there is always one.
    uint8_t src = i;
    if (count_[i] == 0) {
      for (uint8_t d = 1; d < kSagBins; ++d) {
        if (i >= d && count_[i - d]) {
          src = static_cast<uint8_t>(i - d);
          break;
        }
        if (i + d < kSagBins && count_[i + d]) {
          src = static_cast<uint8_t>(i + d);
          break;
        }
      }
    }
    int32_t offset = average_mv[0] - average_mv[src];
    if (offset > 32767) offset = 32767;
    if (offset < -32768) offset = -32768;
    out.offset_mv[i] = static_cast<int16_t>(offset);
  }
  start_mv = static_cast<uint16_t>(average_mv[0]);
  return true;
}

}  // namespace tc

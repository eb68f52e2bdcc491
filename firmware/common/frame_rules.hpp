// The ESC frame's pure decisions (fw::ForceActuators): no HAL, no state of their own, tested
// without booting an image (tests/firmware/read_run/test_read_run_help.cpp).
#pragma once
#include <stdint.h>

namespace fw {

// The v2 bus-voltage filter's constant per frame rate, 1/2^shift per frame: 1/8 at 50-99 Hz,
// 1/16 at 100-199, 1/32 at 200-399, 1/64 at 400 Hz, so its time constant stays about 150 ms.
inline uint8_t filterShiftFor(uint16_t frame_hz) {
  uint8_t shift = 3;
  for (uint16_t hz = 100; hz <= frame_hz && shift < 6; hz = static_cast<uint16_t>(hz * 2)) ++shift;
  return shift;
}

// Sum of the middle two of four ADC readings, each clamped to adc_max (one spike either way
// is ignored): the v2 frame's battery reading in half counts, at most 2 * adc_max.
inline uint16_t middleTwoCounts(const uint16_t (&counts)[4], uint16_t adc_max) {
  uint16_t sum = 0;
  uint16_t lo = 0xFFFF;
  uint16_t hi = 0;
  for (uint8_t k = 0; k < 4; ++k) {
    const uint16_t c = counts[k] < adc_max ? counts[k] : adc_max;
    sum = static_cast<uint16_t>(sum + c);
    if (c < lo) lo = c;
    if (c > hi) hi = c;
  }
  return static_cast<uint16_t>(sum - lo - hi);
}

}  // namespace fw

// gather_store's console protocol: the ranges its sweep settings accept (inclusive). The
// firmware's command table takes its argument ranges from here, and `thrustcal board calibrate`
// checks its options against the same numbers before it sends a command.
#pragma once
#include <stdint.h>

#include "thrustcal/record_limits.hpp"

namespace tc {

constexpr uint16_t kSweepPwmLowestUs = kThrottleMinUs;  // `range MIN MAX`
constexpr uint16_t kSweepPwmHighestUs = kThrottleMaxUs;
constexpr uint16_t kSweepStepMinUs = 1;  // `step US`
constexpr uint16_t kSweepStepMaxUs = 100;
constexpr uint16_t kSweepSettleMinMs = 0;  // `settle MS`
constexpr uint16_t kSweepSettleMaxMs = 10000;
constexpr int16_t kPlateMaxG = 500;         // `plate G`
constexpr int16_t kKnownWeightMaxG = 950;   // `cal W` / `span W`: up to the load cell's overload

}  // namespace tc

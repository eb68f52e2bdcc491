// Force model v2: the model itself (finalize, clear), what both images need. The fitting on the
// board (gather_store, once per sweep) is model_v2_fit.cpp; the run time (bus filter, force ->
// PWM, read_run's frame) is model_v2_runtime.cpp; the host's export of a lab curve is
// tools/core_host/src/model_v2_curve.cpp. See model_v2.hpp for the physics, the fixed-point
// formats and the division count. Every multiplication below states its bound; `int` is 16
// bits on the AVR, so every product that can exceed 16 bits is cast to 32 bits first.
#include "thrustcal/model_v2.hpp"

namespace tc {

// ---- ModelV2 -------------------------------------------------------------------------------

void ModelV2::clear() { *this = ModelV2(); }

bool ModelV2::finalize() {
  inv_step_q22 = 0;
  inv_coarse_q22 = 0;
  split_dg = 0;
  rest_recip_q27 = 0;
  max_force_dg = 0;
  start_q17_us = 0;
  q16_inverse = 0;
  const bool coarse = fine_knots < knots;
  const uint32_t split = static_cast<uint32_t>(fine_knots) * step_dg;
  const uint32_t top = split + static_cast<uint32_t>(knots - fine_knots) * coarse_step_dg;
  bool ok = start_q4_us >= kV2StartMinQ4Us && start_q4_us <= kV2StartMaxQ4Us &&
            step_dg >= (coarse ? kV2MinStepDg : kV2MinStepSmallDg) && knots >= 2 &&
            knots <= kV2MaxKnots && fine_knots >= 1 &&
            fine_knots <= knots && (coarse ? coarse_step_dg >= kV2MinStepDg : coarse_step_dg == 0) &&
            top <= 65535u && isSaneV2Mv(rest_mv) && (second_mv == 0 || isSaneV2Mv(second_mv)) &&
            (!dynamics.isPresent() || dynamics.isValid());
  if (ok) {
    ok = drive_512usmv[0] > 0;
    for (uint8_t k = 1; ok && k < knots; ++k) ok = drive_512usmv[k] >= drive_512usmv[k - 1];
  }
  if (!ok) {
    clear();
    return false;
  }
  for (uint8_t k = knots; k < kV2MaxKnots; ++k) {
    drive_512usmv[k] = 0;
    sag_10mv[k] = 0;
  }
  q16_inverse = step_dg < kV2MinStepDg ? 1 : 0;
  const uint32_t one = q16_inverse ? (1ul << 16) : (1ul << 22);
  inv_step_q22 = static_cast<uint16_t>((one + step_dg / 2) / step_dg);
  if (coarse) inv_coarse_q22 = static_cast<uint16_t>(((1ul << 22) + coarse_step_dg / 2) / coarse_step_dg);
  split_dg = static_cast<uint16_t>(split);
  max_force_dg = static_cast<uint16_t>(top);
  start_q17_us = static_cast<uint32_t>(start_q4_us) << 13;
  rest_recip_q27 = static_cast<uint16_t>(kRecipOne / rest_mv);
  return true;
}

}  // namespace tc

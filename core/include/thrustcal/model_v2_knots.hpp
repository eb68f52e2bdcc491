// Where model v2 puts its knots: shared by the fitter on the board (model_v2_fit.cpp) and the
// host's export of a lab curve (tools/core_host, modelV2FromCurve). One definition, so a model
// fitted on the bench and one exported by the lab have the same knot forces. Inline: the
// fitter is its only caller in the firmware, where it folds into ModelV2FitterBase::fit.
#pragma once
#include <stdint.h>

#include "thrustcal/model_v2.hpp"

namespace tc {

// Chooses the knot forces of a model v2 curve reaching fmax_dg (sets step, knots, fine_knots,
// coarse step and split; knotForceDg() works before finalize()).
inline void placeV2Knots(ModelV2& m, uint16_t fmax_dg) {
  // Two runs when the fine step (a quarter of the range in 16 knots) is at least the minimum.
  const uint16_t fine = static_cast<uint16_t>(fmax_dg / 64);
  if (fine >= kV2MinStepDg) {
    m.step_dg = fine;
    m.fine_knots = 16;
    m.knots = kV2MaxKnots;
    m.coarse_step_dg = static_cast<uint16_t>((fmax_dg - 16u * fine) / 16u);
    m.split_dg = static_cast<uint16_t>(16u * fine);
    return;
  }
  // One run: floor of fmax / 32, at least the minimum step; the last knot <= fmax. Below
  // kV2MinStepDg (curves under 211 g) the knot position uses the Q16 reciprocal.
  uint16_t step = static_cast<uint16_t>(fmax_dg / kV2MaxKnots);
  if (step < kV2MinStepSmallDg) step = kV2MinStepSmallDg;
  const uint16_t n = static_cast<uint16_t>(fmax_dg / step);
  m.step_dg = step;
  m.knots = static_cast<uint8_t>(n > kV2MaxKnots ? kV2MaxKnots : n);
  m.fine_knots = m.knots;
  m.coarse_step_dg = 0;
  m.split_dg = static_cast<uint16_t>(m.knots * step);
}


}  // namespace tc

// Host-side companions of core/ (tools/core_host): code the host tools and tests share with
// the firmware's formats but no image links. Here: a model v2 from a curve given in double
// precision (the model lab's export).
#pragma once
#include <stdint.h>

#include "thrustcal/model_v2.hpp"

namespace tc {

// Fills `out` from a curve given in double precision.
// Points (drive_usv[i], force_g[i]) with drive = (pwm - start) * V in us*V, ascending; dense
// points are best (the curve is resampled linearly onto the knots). sag_mv[i] (may be null)
// is the monitor drop at force_g[i]. Returns false (out cleared) when the points are fewer
// than 2, not ascending, the largest force is outside kRecordMinForceG..kRecordMaxForceG, or
// a field is out of range
// (see ModelV2::finalize).
bool modelV2FromCurve(ModelV2& out, double start_us, const double* drive_usv,
                      const double* force_g, uint16_t count, double rest_mv,
                      const double* sag_mv = nullptr, double second_mv = 0.0);

}  // namespace tc

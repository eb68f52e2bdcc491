// Model v2 from a curve in double precision: the model lab's export (host only, never in an
// image; it moved here out of core/ so core holds only what the firmware links). The knots are
// placed by core's placeV2Knots, the fields checked by core's ModelV2::finalize: a model made
// here is one the board accepts.
#include "thrustcal/model_v2_curve.hpp"

#include "thrustcal/model_v2_knots.hpp"

namespace tc {

bool modelV2FromCurve(ModelV2& out, double start_us, const double* drive_usv,
                      const double* force_g, uint16_t count, double rest_mv,
                      const double* sag_mv, double second_mv) {
  out.clear();
  if (count < 2 || drive_usv == nullptr || force_g == nullptr) return false;
  for (uint16_t i = 1; i < count; ++i) {
    if (!(drive_usv[i] >= drive_usv[i - 1]) || !(force_g[i] >= force_g[i - 1])) return false;
  }
  const double fmax_dg = force_g[count - 1] * 10.0;
  if (!(fmax_dg >= 10.0 * kRecordMinForceG) || !(fmax_dg <= 10.0 * kRecordMaxForceG)) return false;
  const uint16_t fmax = static_cast<uint16_t>(fmax_dg);
  if (!(start_us > 0.0 && start_us < 4000.0) || !(rest_mv > 0.0 && rest_mv < 65535.0) ||
      !(second_mv >= 0.0 && second_mv < 65535.0))
    return false;
  ModelV2 m;
  placeV2Knots(m, fmax);
  m.start_q4_us = static_cast<uint16_t>(start_us * 16.0 + 0.5);
  m.rest_mv = static_cast<uint16_t>(rest_mv + 0.5);
  m.second_mv = static_cast<uint16_t>(second_mv + 0.5);
  m.flags = m.second_mv ? kV2Refined : 0;
  uint16_t i = 1;
  for (uint8_t k = 0; k < m.knots; ++k) {
    const double f = m.knotForceDg(k) / 10.0;
    // Origin (0, 0) before the first point if the points start above zero force.
    double d = 0.0, sag = 0.0;
    if (f <= force_g[0]) {
      const double t = force_g[0] > 0.0 ? f / force_g[0] : 1.0;
      d = drive_usv[0] * t;
      sag = sag_mv ? sag_mv[0] * t : 0.0;
    } else {
      while (i < count - 1 && force_g[i] < f) ++i;
      const double df = force_g[i] - force_g[i - 1];
      const double t = df > 0.0 ? (f - force_g[i - 1]) / df : 1.0;
      d = drive_usv[i - 1] + t * (drive_usv[i] - drive_usv[i - 1]);
      sag = sag_mv ? sag_mv[i - 1] + t * (sag_mv[i] - sag_mv[i - 1]) : 0.0;
    }
    const double units = d * 1000.0 / kDriveUnitUsMv + 0.5;
    m.drive_512usmv[k] = units >= 65535.0 ? 65535 : (units < 1.0 ? 1 : static_cast<uint16_t>(units));
    const double s10 = sag / kV2SagUnitMv + 0.5;
    m.sag_10mv[k] = s10 >= 255.0 ? 255 : (s10 < 0.0 ? 0 : static_cast<uint8_t>(s10));
  }
  if (!m.finalize()) return false;
  out = m;
  return true;
}

}  // namespace tc

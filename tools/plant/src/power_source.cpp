#include "plant/power_source.hpp"

#include <algorithm>
#include <cmath>

namespace plant {

const std::array<OcvPoint, 12> kLipoOcvTable = {{
    {0.00, 3.27}, {0.05, 3.61}, {0.10, 3.69}, {0.20, 3.73}, {0.30, 3.77}, {0.40, 3.80},
    {0.50, 3.84}, {0.60, 3.87}, {0.70, 3.95}, {0.80, 4.02}, {0.90, 4.11}, {1.00, 4.20},
}};

double lipoCellOcv_v(double soc) {
  soc = std::clamp(soc, 0.0, 1.0);
  for (size_t i = 1; i < kLipoOcvTable.size(); ++i) {
    const OcvPoint& a = kLipoOcvTable[i - 1];
    const OcvPoint& b = kLipoOcvTable[i];
    if (soc <= b.soc) return a.cell_v + (soc - a.soc) / (b.soc - a.soc) * (b.cell_v - a.cell_v);
  }
  return kLipoOcvTable.back().cell_v;
}

double socForCellOcv(double cell_v) {
  if (cell_v <= kLipoOcvTable.front().cell_v) return 0.0;
  for (size_t i = 1; i < kLipoOcvTable.size(); ++i) {
    const OcvPoint& a = kLipoOcvTable[i - 1];
    const OcvPoint& b = kLipoOcvTable[i];
    if (cell_v <= b.cell_v) return a.soc + (cell_v - a.cell_v) / (b.cell_v - a.cell_v) * (b.soc - a.soc);
  }
  return 1.0;
}

BatteryParams BatteryParams::lipo3s(double soc) {
  BatteryParams p;
  p.kind = Kind::kLipo;
  p.soc = soc;
  return p;
}

BatteryParams BatteryParams::benchSupply(double set_v, double current_limit_a) {
  BatteryParams p;
  p.kind = Kind::kBenchSupply;
  p.set_v = set_v;
  p.current_limit_a = current_limit_a;
  p.wiring_r_ohm = 0.020;  // short, thick leads from the supply to the ESC
  return p;
}

PowerSource::PowerSource(const BatteryParams& params) : p_(params) { setSoc(params.soc); }

void PowerSource::setSoc(double soc) { soc_ = std::clamp(soc, 0.0, 1.0); }

double PowerSource::openCircuitVoltage_v() const {
  return p_.kind == BatteryParams::Kind::kLipo ? p_.cells * lipoCellOcv_v(soc_) : p_.set_v;
}

double PowerSource::restingVoltage_v() const {
  return p_.kind == BatteryParams::Kind::kLipo ? openCircuitVoltage_v() - v_pol_ : p_.set_v;
}

double PowerSource::solveBusVoltage(const BusLoad& load) const {
  const double g = load.conductance_s;
  const double i0 = load.offset_a;
  limited_ = false;
  if (p_.kind == BatteryParams::Kind::kLipo) {
    const double rt = p_.r_internal_ohm + p_.wiring_r_ohm;
    return std::max(0.0, (restingVoltage_v() - rt * i0) / (1.0 + rt * g));
  }
  const double rt = p_.wiring_r_ohm;
  const double v_cv = std::max(0.0, (p_.set_v - rt * i0) / (1.0 + rt * g));
  if (load.currentAt_a(v_cv) <= p_.current_limit_a) return v_cv;
  // Constant current: the voltage folds back until exactly the limit flows.
  limited_ = true;
  if (g <= 0.0) return 0.0;
  return std::clamp((p_.current_limit_a - i0) / g, 0.0, v_cv);
}

void PowerSource::step(double dt_s, double current_a) {
  drawn_mah_ += current_a * dt_s / 3.6;
  if (p_.kind != BatteryParams::Kind::kLipo) return;
  setSoc(soc_ - current_a * dt_s / (3.6 * p_.capacity_mah));
  // Polarization RC, implicit Euler (stable for any dt).
  const double k = dt_s / p_.tau_polarization_s;
  v_pol_ = (v_pol_ + k * current_a * p_.r_polarization_ohm) / (1.0 + k);
}

}  // namespace plant

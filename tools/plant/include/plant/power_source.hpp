// Power for the ESCs: a 3S LiPo pack or a current-limited bench supply, plus the wiring from
// it to the ESC / battery-monitor point (the power distribution board).
//
// LiPo: V_terminal = OCV(SoC) - I R_internal - V_polarization, where V_polarization is an RC
//   pair (R_pol, tau_pol): the pack sags further under a long load and recovers afterwards
//   (this is what makes "resting voltage before and after" differ from the loaded voltage).
//   SoC falls by I dt / capacity.
// Bench supply: constant voltage up to current_limit_a, then constant current (the voltage
//   folds back so that exactly the limit flows; thesis: 6.32 A, two 3.16 A outputs in parallel).
// Both: V_bus = V_terminal - I wiring_r_ohm.
//
// Per step the loads are affine in V_bus (see BusLoad) so the bus voltage is solved exactly,
// with no iteration and no lag between current and voltage.
#pragma once
#include <array>
#include "plant/actuator.hpp"

namespace plant {

// The per-cell open-circuit voltage (tools/plant/README.md) at SoC 0, 5, 10, 20, ..., 100 %.
struct OcvPoint {
  double soc;     // 0..1
  double cell_v;
};
extern const std::array<OcvPoint, 12> kLipoOcvTable;
// Linear interpolation in kLipoOcvTable, SoC clamped to 0..1.
double lipoCellOcv_v(double soc);
// Inverse: SoC for a per-cell OCV (clamped to the table's range). Handy to start a pack at a
// given resting voltage: socForCellOcv(11.35 / 3).
double socForCellOcv(double cell_v);

struct BatteryParams {
  enum class Kind { kLipo, kBenchSupply };
  Kind kind = Kind::kLipo;
  // LiPo
  int cells = 3;
  double capacity_mah = 3000.0;
  double soc = 1.0;                    // initial state of charge, 0..1
  double r_internal_ohm = 0.030;       // pack, ohmic
  double r_polarization_ohm = 0.012;   // pack, RC pair
  double tau_polarization_s = 20.0;
  // Bench supply
  double set_v = 12.0;
  double current_limit_a = 6.32;
  // Both: leads + distribution from the source to the ESC / monitor point.
  double wiring_r_ohm = 0.045;  // LiPo harness, connectors, distribution (fits thesis fig. 6.1)

  static BatteryParams lipo3s(double soc = 1.0);
  static BatteryParams benchSupply(double set_v, double current_limit_a = 6.32);
};

class PowerSource {
 public:
  explicit PowerSource(const BatteryParams& params = BatteryParams());

  // Bus voltage (at the ESC / monitor point) that the given total load draws; does not change
  // state. Never negative.
  double solveBusVoltage(const BusLoad& load) const;
  // Advance by dt_s with total bus current current_a (drains the pack, polarization).
  void step(double dt_s, double current_a);

  // Terminal voltage with no load right now (bench: set voltage; LiPo: OCV - polarization).
  double restingVoltage_v() const;
  // Open-circuit voltage (LiPo: from SoC; bench: set voltage).
  double openCircuitVoltage_v() const;
  double soc() const { return soc_; }
  void setSoc(double soc);
  double drawnCharge_mah() const { return drawn_mah_; }
  bool isCurrentLimited() const { return limited_; }  // during the last solve (bench supply)
  const BatteryParams& params() const { return p_; }
  void setSetVoltage(double set_v) { p_.set_v = set_v; }

 private:
  BatteryParams p_;
  double soc_ = 1.0;
  double v_pol_ = 0.0;
  double drawn_mah_ = 0.0;
  mutable bool limited_ = false;
};

}  // namespace plant

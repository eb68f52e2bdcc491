#include "plant/params.hpp"

#include <stdexcept>

#include "plant/random.hpp"

namespace plant {

namespace {

// Propellers (APC slow-flyer, static). C_T at the datasheet rpm matches T-motor's thrust there;
// the rise of C_T with rpm follows UIUC's static data for the 9x4.7 SF.
PropellerParams apc9x47() { return PropellerParams{}; }

PropellerParams apc10x38() {
  PropellerParams p;
  p.diameter_m = 0.254;
  p.ct_low = 0.124;
  p.ct_high = 0.131;
  p.cp_low = 0.052;
  p.cp_high = 0.054;
  p.rpm_low = 2800.0;
  p.rpm_high = 6000.0;
  p.inertia_kgm2 = 6.0e-5;
  p.mass_g = 13.0;
  return p;
}

PropellerParams apc11x47() {
  PropellerParams p;
  p.diameter_m = 0.2794;
  p.ct_low = 0.118;
  p.ct_high = 0.125;
  p.cp_low = 0.050;
  p.cp_high = 0.052;
  p.rpm_low = 2800.0;
  p.rpm_high = 5300.0;
  p.inertia_kgm2 = 9.0e-5;
  p.mass_g = 18.0;
  return p;
}

MotorParams mt2208kv1100() { return MotorParams{}; }

MotorParams mt2216kv900() {
  MotorParams m;
  m.kv_rpm_per_v = 900.0;
  m.r_winding_ohm = 0.110;
  m.i0_a = 0.30;
  m.rotor_inertia_kgm2 = 6.0e-6;
  m.heat_capacity_j_per_k = 35.0;
  m.thermal_resistance_k_per_w = 3.5;
  m.mass_g = 75.0;
  return m;
}

Preset make(const std::string& name, const std::string& description, MotorParams motor,
            PropellerParams prop, DatasheetPoint ds) {
  Preset p;
  p.params.name = name;
  p.params.motor = motor;
  p.params.prop = prop;
  p.description = description;
  p.datasheet = ds;
  return p;
}

}  // namespace

const std::vector<Preset>& presets() {
  static const std::vector<Preset> kPresets = {
      make("kv1100_9x4.7", "T-motor MT2208 KV1100 + APC 9x4.7 SF (thesis main; fits table 5.1)",
           mt2208kv1100(), apc9x47(), {11.1, 0.75, 6.4, 500.0, 6600.0}),
      make("kv1100_10x3.8", "T-motor MT2208 KV1100 + APC 10x3.8 SF", mt2208kv1100(), apc10x38(),
           {11.1, 0.75, 7.6, 590.0, 5600.0}),
      make("kv900_10x3.8", "T-motor MT2216 KV900 + APC 10x3.8 SF", mt2216kv900(), apc10x38(),
           {11.1, 0.75, 7.9, 670.0, 6000.0}),
      make("kv900_11x4.7", "T-motor MT2216 KV900 + APC 11x4.7 SF", mt2216kv900(), apc11x47(),
           {11.1, 0.75, 8.6, 730.0, 5298.0}),
  };
  return kPresets;
}

std::optional<Preset> findPreset(const std::string& name) {
  for (const Preset& p : presets()) {
    if (p.params.name == name) return p;
  }
  return std::nullopt;
}

ActuatorParams presetParams(const std::string& name) {
  if (auto p = findPreset(name)) return p->params;
  std::string known;
  for (const Preset& p : presets()) known += (known.empty() ? "" : ", ") + p.params.name;
  throw std::invalid_argument("unknown plant preset '" + name + "'; use one of: " + known +
                              " (see `thrustcal plant presets`)");
}

ActuatorParams makeVaried(const ActuatorParams& base, uint64_t seed, double spread) {
  if (spread <= 0.0) return base;
  // Mix the seed so that seeds 1, 2, 3 give unrelated streams.
  Rng rng(seed * 0x9E3779B97F4A7C15ULL + 0x632BE59BD9B4E019ULL);
  auto scale = [&](double s) { return 1.0 + rng.normal(s, 3.0); };
  ActuatorParams p = base;
  p.motor.kv_rpm_per_v *= scale(spread);
  p.motor.r_winding_ohm *= scale(spread);
  p.motor.i0_a *= scale(spread);
  p.motor.rotor_inertia_kgm2 *= scale(spread);
  const double half = 0.5 * spread;
  const double ct = scale(half);
  p.prop.ct_low *= ct;
  p.prop.ct_high *= ct;
  const double cp = scale(half);
  p.prop.cp_low *= cp;
  p.prop.cp_high *= cp;
  p.prop.diameter_m *= scale(0.25 * spread);
  p.prop.inertia_kgm2 *= scale(spread);
  p.esc.start_us += rng.normal(4.0 * spread / 0.03, 3.0);  // ESC endpoints differ by a few us
  p.esc.r_esc_ohm *= scale(spread);
  p.name = base.name + "#" + std::to_string(seed);
  return p;
}

}  // namespace plant

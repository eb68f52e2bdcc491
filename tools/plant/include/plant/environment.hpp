// Air around the bench or the aircraft.
#pragma once

namespace plant {

constexpr double kGravity_m_per_s2 = 9.80665;
constexpr double kAirGasConstant_j_per_kgk = 287.05;

struct Environment {
  double temp_c = 20.0;          // air temperature (also the motors' ambient)
  double pressure_pa = 101325.0; // static pressure

  // Dry-air density rho = p / (287.05 * T), kg/m^3. 1.204 at 20 C and 101325 Pa.
  double airDensity_kg_per_m3() const {
    return pressure_pa / (kAirGasConstant_j_per_kgk * (temp_c + 273.15));
  }
};

}  // namespace plant

// The dynamics record of a plant motor (plant/dynamics_record.hpp).
#include "plant/dynamics_record.hpp"

#include <stdexcept>

#include "plant/actuator.hpp"
#include "plant/fidelity.hpp"
#include "thrustcal/dynamics_fit.hpp"

namespace plant {

tc::MotorDynamics recordDynamics(const ActuatorParams& motor, double scale) {
  constexpr double kBusV = 11.5;
  const Actuator a(motor);
  double max_g = 0;
  for (int p = 1000; p <= 1800; p += 5) max_g = std::max(max_g, a.steadyState(p, kBusV).thrust_g);
  tc::DynamicsLawFit law;
  for (int i = 1; i <= 5; ++i) {  // dyn's points: 20..80 % of the force, stepped +-10 us here
    const double want_g = max_g * (0.05 + 0.15 * i);
    int pulse = 1000;
    while (pulse < 1800 && a.steadyState(pulse, kBusV).thrust_g < want_g) pulse += 5;
    const double up = scale * stepTimeConstant_s(motor, kBusV, pulse - 10, pulse + 10);
    const double down = scale * stepTimeConstant_s(motor, kBusV, pulse + 10, pulse - 10);
    law.add(static_cast<float>(want_g), static_cast<float>(up), static_cast<float>(down));
  }
  tc::MotorDynamics d;
  if (!law.build(d)) throw std::runtime_error(motor.name + ": the plant's time constants make no storable law");
  return d;
}

}  // namespace plant

// The dynamics record (thrustcal/dynamics.hpp) gather_store's `dyn` would store for a plant motor,
// from the plant's own step time constants: what the swap's force+dyn runs can fly without
// running `dyn` (`thrustcal sim swap --dyn-from plant`) and what the bench's corrected sweeps
// use. `thrustcal bench dynamics` shows `dyn` measures the same within a few percent.
#pragma once
#include "plant/params.hpp"
#include "thrustcal/dynamics.hpp"

namespace plant {

// The law over dyn's five operating points (20..80 % of the motor's force at 11.5 V, +-10 us
// steps), every time constant times `scale`. Throws std::runtime_error naming the motor when the
// time constants make no storable law.
tc::MotorDynamics recordDynamics(const ActuatorParams& motor, double scale = 1.0);

}  // namespace plant

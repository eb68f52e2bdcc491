// `dyn on|off [UP_MS DOWN_MS]`: equal dynamics in flight on the force API
// (ForceActuators::setShaping, thrustcal/dyn_shaper.hpp), the same words in read_run and fly.
//   dyn on               every motor with measured dynamics follows the slowest of them
//   dyn on 110 110       ... follows a fixed first-order response, spin-up 110 ms, down 110 ms
//   dyn off              every motor flies its force as commanded (the default at start-up)
// The image checks that no motor runs before it calls dynCommand.
#pragma once
#include <stdint.h>

#include "force_actuators.hpp"
#include "shell.hpp"

namespace fw {

// Argument specs of the console row (`dyn on|off [UP_MS DOWN_MS]`): on = 0, off = 1.
extern const ArgSpec kDynArgs[3];  // TC_FLASH
constexpr uint8_t kDynMinArgs = 1;
constexpr uint8_t kDynMaxArgs = 3;
extern const char kDynName[];      // TC_FLASH "dyn"
extern const char kDynHelp[];      // TC_FLASH, the help row

// Switches shaping as `args` say and answers with dynState's line, or one error line (nothing
// changed): time constants with off, only one of them, no motor with dynamics.
void dynCommand(ForceActuators& motors, const ArgValues& args);
// "dyn on: motors 0 1 2 3 follow the slowest motor's response" / "... a fixed response, up
// 110 ms, down 110 ms" (and "; motor N flies unshaped (no dynamics)"), or "dyn off: ...".
void dynState(const ForceActuators& motors);

}  // namespace fw

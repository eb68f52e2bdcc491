// The bench's calibrated aircraft: four varied KV1100 + APC 9x4.7 motors (plant::makeVaried,
// seeds 11-14, 3 % spread), each swept on the host on the simulated thesis bench as gather_store
// sees a sweep (bench/sweeps.hpp: a LiPo resting at 12.4 V, then a 10.5 V bench supply), and the
// EEPROM images gather_store writes from such sweeps, made with core/'s own builders and codecs:
//   v1  the thesis's two curves per motor (store 1 on the LiPo with its sag offsets, store 2 on
//       the supply), the thesis layout;
//   v2  model v2 fitted on the LiPo sweep and refined by the supply sweep (store v2, two copies).
// Also ArduPilot's thrust parameters fitted once for all four motors from the same sweeps (what
// `thrustcal lab export --to ardupilot` gives an aircraft: one curve for every motor).
// Read_run's runtime bench and fly's bench fly them; built once per process.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "bench/accuracy.hpp"
#include "plant/params.hpp"

namespace bench {

struct BenchRecords {
  std::array<plant::ActuatorParams, 4> motors;  // ESC output / slot i: motor i
  std::vector<uint8_t> v1, v2;                  // whole EEPROM images (sim::kEepromBytes)
  std::vector<uint8_t> v2_dyn;                  // v2 with each motor's dynamics: the plant's own
                                                // time constants (bench::plantDynamics; what
                                                // gather_store's dyn measures within 5 %)
  ExpoModel ardupilot;                          // one fit over the four motors' sweeps
};

// Throws std::runtime_error naming the motor when a curve, fit or record cannot be made.
const BenchRecords& benchRecords();

}  // namespace bench

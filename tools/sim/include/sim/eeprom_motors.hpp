// Which simulated motors an EEPROM image's records were made for. `sim gather --eeprom FILE`
// writes FILE.motors.json beside the image: per calibrated slot the motor preset, its seed and
// the part-to-part variation (the plant's motor is motorForSeed(preset, seed, variation)).
// `sim console --eeprom FILE` flies those motors unless told otherwise, and says plainly when
// the motors it flies are not the ones the records were measured on (docs/sim.md).
//
//   {"format": "thrustcal eeprom motors 1",
//    "slots": [{"slot": 0, "preset": "kv1100_9x4.7", "seed": 11, "variation": 0.03}, ...]}
#pragma once
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace sim {

struct SlotMotor {
  std::string preset;
  uint64_t seed = 0;
  double variation = 0.03;
};

struct EepromMotors {
  std::array<std::optional<SlotMotor>, 4> slots;  // empty: nothing known of that slot
};

// FILE + ".motors.json".
std::string eepromMotorsPath(const std::string& eeprom_path);
// The sidecar of `eeprom_path`; nothing when there is none. Throws std::runtime_error naming
// the file and what is wrong in it when it cannot be read.
std::optional<EepromMotors> readEepromMotors(const std::string& eeprom_path);
// Writes the sidecar (whole), throws std::runtime_error when it cannot.
void writeEepromMotors(const std::string& eeprom_path, const EepromMotors& motors);
// After a gather of `slots` with `seeds` (one each): the sidecar as it was, those slots replaced.
void recordGatheredMotors(const std::string& eeprom_path, const std::string& preset, double variation,
                          const std::vector<int>& slots, const std::vector<uint64_t>& seeds);

// The four motors a console flies for an image, and what to tell the user about them.
struct ConsoleMotors {
  std::array<SlotMotor, 4> motors;
  std::vector<std::string> notes;  // one line each: what was chosen and any mismatch
};
// `seeds` / `preset`: the command line's (given: whether the user typed them). Without them the
// sidecar's motors, else the given ones, and a warning for each slot whose record was made for
// another motor.
ConsoleMotors chooseConsoleMotors(const std::string& eeprom_path, const std::vector<uint64_t>& seeds,
                                  bool seeds_given, const std::string& preset, bool preset_given);

}  // namespace sim

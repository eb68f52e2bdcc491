// Fuzz targets for the host parsers: each takes arbitrary bytes, must never crash, hang or hit
// undefined behaviour, and checks what its parser promises (fuzz::violation() aborts with a
// message when a promise breaks, which libFuzzer and the replay test both report).
//   intel_hex       hex::parseIntelHex (EEPROM images for avrdude, `sim`, `lab export`):
//                   accepted images round-trip through formatIntelHex byte for byte
//   eeprom_image    tc::loadSlot / readRecord / readModelV2 / readSettings on any 4 KiB image:
//                   whatever loads is plausible (checkCalibration / checkModelV2) and flies
//                   inside the ESC range at every force and bus voltage
//   column_map      lab::parseColumnMap (`--map TARGET=SOURCE...`) applied while reading a CSV
//   lab_expression  lab::parseSpec + lab::Model with `mul:`/`add:` expressions (muParser)
//   lab_csv         lab::parseText on any text (the project CSV, gather_store logs, RCbenchmark)
// Built twice: into the libFuzzer binaries of the `fuzz` preset (tests/fuzz/libfuzzer_main.cpp)
// and into fuzz_replay_tests, which ctest runs on every build (tests/fuzz/fuzz_replay_test.cpp).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace fuzz {

using Run = void (*)(const uint8_t* data, std::size_t size);

struct Target {
  const char* name;
  Run run;
  std::vector<std::string> (*seeds)();  // valid-looking inputs to start from
};

// The targets, in the order above.
const std::vector<Target>& targets();
const Target* findTarget(const std::string& name);

void intelHex(const uint8_t* data, std::size_t size);
void eepromImage(const uint8_t* data, std::size_t size);
void columnMap(const uint8_t* data, std::size_t size);
void labExpression(const uint8_t* data, std::size_t size);
void labCsv(const uint8_t* data, std::size_t size);

// A broken promise: prints `what` and aborts.
[[noreturn]] void violation(const std::string& what);

}  // namespace fuzz

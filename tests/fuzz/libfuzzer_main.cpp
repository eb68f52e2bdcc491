// libFuzzer entry for one target (the `fuzz` preset builds one binary per target, each with
// FUZZ_TARGET_FN set to one of fuzz::intelHex, fuzz::eepromImage, ...). Run it with the seed
// corpus the replay test writes: build/fuzz/tests/fuzz/fuzz_intel_hex corpus/intel_hex
// (tools/fuzz.sh does). A crash leaves the input in crash-*: copy it into
// tests/fuzz/regressions/<target>/ so fuzz_replay_tests replays it on every build.
#include <cstddef>
#include <cstdint>

#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  FUZZ_TARGET_FN(data, size);
  return 0;
}

// `dyn on|off [UP_MS DOWN_MS]` (dyn_console.hpp).
#include "dyn_console.hpp"

#include "console.hpp"

namespace fw {

namespace {
const char kOnOffWords[] TC_FLASH = "on|off";
const char kUpMs[] TC_FLASH = "UP_MS";
const char kDownMs[] TC_FLASH = "DOWN_MS";
constexpr int32_t kTauMinMs = (tc::kDynTauMin01ms + 9) / 10;
constexpr int32_t kTauMaxMs = tc::kDynTauMax01ms / 10;
}  // namespace

const ArgSpec kDynArgs[3] TC_FLASH = {
    {kOnOffWords, kOnOffWords, 0, 0}, {kUpMs, nullptr, kTauMinMs, kTauMaxMs}, {kDownMs, nullptr, kTauMinMs, kTauMaxMs}};
const char kDynName[] TC_FLASH = "dyn";
const char kDynHelp[] TC_FLASH = "motors follow one lag: the slowest's, or fixed";

void dynState(const ForceActuators& motors) {
  if (!motors.isShaping()) {
    sayLine(TC_FLASH_TEXT("dyn off: every motor flies its force as commanded"));
    return;
  }
  say(TC_FLASH_TEXT("dyn on: motors"));
  for (uint8_t i = 0; i < ForceActuators::kMotors; ++i) {
    if (!motors.motor(i).shaper.isActive()) continue;
    say(TC_FLASH_TEXT(" "));
    printUint(i);
  }
  const tc::ShaperReference& ref = motors.shapingReference();
  if (ref.isSlowest()) {
    say(TC_FLASH_TEXT(" follow the slowest motor's response"));
  } else {
    say(TC_FLASH_TEXT(" follow a fixed response, up "));
    printFixed(ref.tau_up_01ms, 1);
    say(TC_FLASH_TEXT(" ms, down "));
    printFixed(ref.tau_down_01ms, 1);
    say(TC_FLASH_TEXT(" ms"));
  }
  for (uint8_t i = 0; i < ForceActuators::kMotors; ++i) {
    if (motors.motor(i).shaper.isActive() || !motors.isArmable(i)) continue;
    say(TC_FLASH_TEXT("; motor "));
    printUint(i);
    say(TC_FLASH_TEXT(" flies unshaped (no dynamics)"));
  }
  newline();
}

void dynCommand(ForceActuators& motors, const ArgValues& args) {
  const bool on = args[0] == 0;
  if (!on) {
    if (args.count > 1) {
      sayLine(TC_FLASH_TEXT("error: dyn off takes no time constants; nothing changed"));
      return;
    }
    motors.clearShaping();
    dynState(motors);
    return;
  }
  if (args.count == 2) {
    sayLine(TC_FLASH_TEXT("error: dyn on takes both UP_MS and DOWN_MS, or neither; nothing changed"));
    return;
  }
  tc::ShaperReference reference;  // slowest
  if (args.count == 3) {
    reference.tau_up_01ms = static_cast<uint16_t>(args[1] * 10);
    reference.tau_down_01ms = static_cast<uint16_t>(args[2] * 10);
  }
  if (motors.setShaping(reference) != ForceActuators::Shaping::kOn) {
    sayLine(TC_FLASH_TEXT("error: dyn: no calibrated motor has dynamics; measure them with "
                          "gather_store's dyn, then store v2"));
    return;
  }
  dynState(motors);
}

}  // namespace fw

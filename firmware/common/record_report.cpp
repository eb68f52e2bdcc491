// Record and settings reports shared by gather_store and read_run (record_report.hpp).
#include "record_report.hpp"

#include "console.hpp"
#include "hal/hal.hpp"
#include "thrustcal/eeprom_store.hpp"

namespace fw {

namespace {

// tc::printPlausibility's output: flash texts and fixed-point numbers on the UART.
struct UartOut {
  void flash(const char* text) { hal::Uart::printP(text); }
  void fixed(int32_t value, uint8_t decimals) { printFixed(value, decimals); }
};

}  // namespace

void printRecordStatus(tc::DecodeStatus status, const tc::Plausibility& why) {
  if (status == tc::DecodeStatus::kBadContent && !why.ok()) {
    hal::Uart::printP(TC_FLASH_TEXT("implausible: "));
    UartOut out;
    tc::printPlausibility(why, out);
    return;
  }
  hal::Uart::print(tc::decodeStatusText(status));
}

void printDivider(const tc::BoardSettings& settings) {
  hal::Uart::printP(TC_FLASH_TEXT("divider "));
  printUint(settings.divider_top_ohm);
  hal::Uart::write('/');
  printUint(settings.divider_bottom_ohm);
  hal::Uart::printP(TC_FLASH_TEXT(" ohm, full scale "));
  printFixed(settings.fullScaleMv(), 3);
  hal::Uart::printP(TC_FLASH_TEXT(" V"));
  if (settings.isDefault()) hal::Uart::printP(TC_FLASH_TEXT(" (thesis default)"));
}

bool setDivider(uint32_t top_ohm, uint32_t bottom_ohm, tc::BoardSettings& settings) {
  tc::BoardSettings wanted = settings;  // the rest of the settings (the bench's response) stays
  wanted.divider_top_ohm = top_ohm;
  wanted.divider_bottom_ohm = bottom_ohm;
  if (!wanted.isValid()) {
    hal::Uart::printP(TC_FLASH_TEXT("error: divider "));
    printUint(wanted.divider_top_ohm);
    hal::Uart::write('/');
    printUint(wanted.divider_bottom_ohm);
    sayLine(TC_FLASH_TEXT(" ohm gives a full scale outside 5..60 V or R2 below 100 ohm: check the "
                    "resistors; nothing changed"));
    return false;
  }
  const tc::SettingsWrite w = tc::storeSettings<hal::Eeprom>(wanted);
  if (w.status == tc::SettingsWriteStatus::kNoRoom) {
    sayLine(TC_FLASH_TEXT("error: no room for the setting: all four slots hold thesis (v1) records, "
                    "which fill the EEPROM; store one motor as model v2 or erase one slot, then "
                    "set the divider again; nothing changed"));
    return false;
  }
  if (w.status == tc::SettingsWriteStatus::kVerifyFailed) {
    sayLine(TC_FLASH_TEXT("error: read-back of the setting failed (EEPROM worn?); the previous divider "
                    "is kept"));
    return false;
  }
  settings = wanted;
  printDivider(settings);
  hal::Uart::printP(w.status == tc::SettingsWriteStatus::kUnchanged ? TC_FLASH_TEXT(", already stored")
                                                                      : TC_FLASH_TEXT(", stored"));
  hal::Uart::printP(TC_FLASH_TEXT(" (motor "));
  printUint(w.host);
  hal::Uart::printP(TC_FLASH_TEXT("'s slot, copy "));
  hal::Uart::write(w.copy == 0 ? 'A' : 'B');
  sayLine(TC_FLASH_TEXT(")"));
  return w.status == tc::SettingsWriteStatus::kWritten;
}

}  // namespace fw

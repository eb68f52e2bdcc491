// Reset flags, watchdog and stack paint (docs/safety.md).
//
// .init3 (after avr-libc's .init2 has set r1 = 0 and SP = RAMEND, before .data/.bss are
// initialised and long before main) runs tc_boot_init3():
//  1. saves the reset flags (MCUSR) and whether the program was running when the chip reset
//     (a marker in .noinit that main sets through Watchdog::start(); SRAM keeps it through a
//     watchdog, external or brown-out reset, a power-up leaves noise);
//  2. clears MCUSR and switches the watchdog off. After a watchdog reset the ATmega2560 restarts
//     with the watchdog still on at its shortest period (16 ms); an image that does not switch it
//     off first resets again and again (WDRF must be cleared before WDE can be);
//  3. paints every SRAM byte between the end of the static data (_end) and RAMEND with
//     hal::kStackPaint, so the stack's high-water mark can be read later (hal::Stack).
//
// The stock Arduino Mega2560 bootloader (stk500v2) reads and clears MCUSR before the program
// starts, so behind it MCUSR reads 0. (Its shortcut after a watchdog reset, an eicall to the
// program, lands at 0x20000 because its start-up code sets EIND = 1: the CPU runs through the
// erased flash into the bootloader again, which then waits its second for an upload and starts
// the program normally. Seen in simavr with stk500boot_v2_mega2560.hex.) The marker still tells
// a reset while running (watchdog, or the reset button) from a power-up.
#include <avr/io.h>
#include <avr/wdt.h>

#include "hal/hal.hpp"

namespace {
constexpr uint32_t kRunningMagic = 0x7C3A51E9;
}  // namespace

extern "C" {
extern uint8_t _end;  // first byte after .data, .bss and .noinit (linker script)
// .noinit: not cleared by the C start-up code that runs after tc_boot_init3().
uint8_t tc_reset_mcusr __attribute__((section(".noinit")));
uint8_t tc_reset_was_running __attribute__((section(".noinit")));
uint32_t tc_running_marker __attribute__((section(".noinit")));

void tc_boot_init3() __attribute__((naked, used, section(".init3")));
void tc_boot_init3() {
  tc_reset_mcusr = MCUSR;
  tc_reset_was_running = tc_running_marker == kRunningMagic;
  tc_running_marker = 0;
  MCUSR = 0;
  wdt_disable();
  // Nothing is on the stack yet (SP = RAMEND, no call made): paint all of it.
  for (uint8_t* p = &_end; p <= reinterpret_cast<uint8_t*>(RAMEND); ++p) *p = hal::kStackPaint;
}
}

namespace hal {

void Watchdog::start() {
  tc_running_marker = kRunningMagic;
  wdt_enable(WDTO_60MS);
}

void Watchdog::kick() { wdt_reset(); }

uint8_t Watchdog::resetFlags() {
  return static_cast<uint8_t>(tc_reset_mcusr | (tc_reset_was_running ? kWasRunning : 0));
}

uint16_t Stack::sizeBytes() {
  return static_cast<uint16_t>(RAMEND + 1 - reinterpret_cast<uint16_t>(&_end));
}

uint16_t Stack::untouchedBytes(void (*yield)()) {
  const uint8_t* p = &_end;
  const uint8_t* const top = reinterpret_cast<const uint8_t*>(RAMEND);
  uint16_t n = 0;
  while (p <= top && *p == hal::kStackPaint) {
    ++p;
    ++n;
    if (yield != nullptr && (n & 63) == 0) yield();
  }
  return n;
}

}  // namespace hal

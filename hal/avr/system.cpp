// Reset flags, watchdog and stack paint (docs/safety.md).
//
// .init3 (after avr-libc's .init2 has set r1 = 0 and SP = RAMEND, before .data/.bss are
// initialised and long before main) runs bootInit():
//  1. saves the reset flags: MCUSR, and r25 with the three bytes on top of the stack (see
//     below), into .noinit;
//  2. clears MCUSR and switches the watchdog off. After a watchdog reset the ATmega2560 restarts
//     with the watchdog still on at its shortest period (16 ms); an image that does not switch it
//     off first resets again and again (WDRF must be cleared before WDE can be);
//  3. paints every SRAM byte between the end of the static data (_end) and RAMEND with
//     kStackPaint, so the stack's high-water mark can be read later (hal::Stack).
//
// The stock Arduino Mega2560 bootloader (stk500v2, stk500boot_v2_mega2560.hex) reads MCUSR into
// r25, clears it, and after a watchdog reset jumps to the application at once with `eicall`
// (r25 still holding the flags, its return address 0x1F311 on top of the stack: bytes
// 01 F3 11 at RAMEND-2..RAMEND). Through any other path it leaves with `ijmp`, pushing nothing.
// So when MCUSR reads 0 and exactly that hand-off is found, the flags are r25's.
#include <avr/io.h>
#include <avr/wdt.h>

#include "hal/hal.hpp"

namespace {
constexpr uint8_t kStackPaint = 0xC5;
constexpr uint32_t kStk500v2WatchdogReturn = 0x1F311;  // word address after its eicall
}  // namespace

extern "C" {
extern uint8_t _end;  // first byte after .data, .bss and .noinit (linker script)
// Saved by bootInit(); .noinit: not cleared by the C start-up code that runs after it.
uint8_t tc_reset_mcusr __attribute__((section(".noinit")));
uint8_t tc_reset_r25 __attribute__((section(".noinit")));
uint8_t tc_reset_stack_top[3] __attribute__((section(".noinit")));

void tc_boot_init3() __attribute__((naked, used, section(".init3")));
void tc_boot_init3() {
  // r25 first, before the compiler may use it.
  __asm__ __volatile__("sts tc_reset_r25, r25" ::: "memory");
  tc_reset_mcusr = MCUSR;
  uint8_t* const top = reinterpret_cast<uint8_t*>(RAMEND - 2);
  tc_reset_stack_top[0] = top[0];
  tc_reset_stack_top[1] = top[1];
  tc_reset_stack_top[2] = top[2];
  MCUSR = 0;
  wdt_disable();
  // Nothing is on the stack yet (SP = RAMEND, no call made): paint all of it.
  for (uint8_t* p = &_end; p <= reinterpret_cast<uint8_t*>(RAMEND); ++p) *p = kStackPaint;
}
}

namespace hal {

void Watchdog::start() { wdt_enable(WDTO_60MS); }

void Watchdog::kick() { wdt_reset(); }

uint8_t Watchdog::resetFlags() {
  if (tc_reset_mcusr != 0) return tc_reset_mcusr;
  const uint32_t ret = (static_cast<uint32_t>(tc_reset_stack_top[0]) << 16) |
                       (static_cast<uint16_t>(tc_reset_stack_top[1]) << 8) | tc_reset_stack_top[2];
  if (ret == kStk500v2WatchdogReturn && (tc_reset_r25 & _BV(WDRF)) != 0 &&
      (tc_reset_r25 & 0xE0) == 0) {
    return static_cast<uint8_t>(tc_reset_r25 | kViaBootloader);
  }
  return 0;
}

uint16_t Stack::sizeBytes() {
  return static_cast<uint16_t>(RAMEND + 1 - reinterpret_cast<uint16_t>(&_end));
}

uint16_t Stack::untouchedBytes() {
  const uint8_t* p = &_end;
  const uint8_t* const top = reinterpret_cast<const uint8_t*>(RAMEND);
  uint16_t n = 0;
  while (p <= top && *p == kStackPaint) {
    ++p;
    ++n;
  }
  return n;
}

}  // namespace hal

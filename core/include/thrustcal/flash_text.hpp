// The one way to keep constant data in flash: on the AVR texts and tables stay in program memory
// (avr-libc's PSTR / PROGMEM, read back with the pgm_ routines); on the host they are ordinary
// data, so the same code runs in host tests.
//   TC_FLASH_TEXT("...")        a text literal in flash (an expression: pass it, return it)
//   const char kName[] TC_FLASH  an array or table in flash
//   tc::flashByte(p)            one byte of either
//   tc::flashCopy(dst, p, n)    n bytes of either into RAM (a table row)
//   tc::flashWordIndex(w, t)    which of the '|'-separated words in flash `w` the RAM text `t` is
//   tc::flashWordCopy(w, i, o, n)  word i of them into RAM
// A pointer into flash is a flash address on the AVR: print it with hal::Uart::printP, never
// with a RAM string routine.
#pragma once
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>
#define TC_FLASH_TEXT(s) PSTR(s)
#define TC_FLASH PROGMEM
#else
#define TC_FLASH_TEXT(s) (s)
#define TC_FLASH
#endif

namespace tc {

inline uint8_t flashByte(const char* p) {
#if defined(__AVR__)
  return pgm_read_byte(p);
#else
  return static_cast<uint8_t>(*p);
#endif
}

inline void flashCopy(void* dst, const void* src, size_t length) {
#if defined(__AVR__)
  memcpy_P(dst, src, length);
#else
  memcpy(dst, src, length);
#endif
}

// The index of `text` (RAM) among the '|'-separated `words` (flash: "plus|x|seesaw"), or -1.
// Whole words only, case-sensitive (the shell's word arguments, the parameters' words).
int8_t flashWordIndex(const char* words, const char* text);
// Word `index` of the '|'-separated `words` (flash) into `out` (`size` bytes, terminated): its
// length, cut to size - 1; 0 (an empty `out`) when there are not that many words.
uint8_t flashWordCopy(const char* words, uint8_t index, char* out, uint8_t size);

}  // namespace tc

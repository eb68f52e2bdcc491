// The AVR side of sim/cycle_probe.hpp (avr-g++, C++14): what a program writes to be measured.
//   markStart(label) ... markEnd()   a timed section (label 1..0x7F; label 0: the empty
//                                    bracket, measured once first, is the marker overhead)
//   report8 / report16(key, value)   values under a key (0x80..0xFE), bytes in order
//   done()                           the run is over (the host stops)
#pragma once
#include <avr/io.h>
#include <stdint.h>

namespace probe {

inline void markStart(uint8_t label) {
  GPIOR1 = label;
  GPIOR0 = 1;
}
inline void markEnd() { GPIOR0 = 2; }
inline void report8(uint8_t key, uint8_t value) {
  GPIOR1 = key;
  GPIOR2 = value;
}
inline void report16(uint8_t key, uint16_t value) {
  GPIOR1 = key;
  GPIOR2 = static_cast<uint8_t>(value);
  GPIOR2 = static_cast<uint8_t>(value >> 8);
}
inline void done() { GPIOR1 = 0xFF; }

}  // namespace probe

// simavr's MCU tag for C++ images. Include after <avr/avr_mcu_section.h>, then use AVR_MCU and
// AVR_MCU_VOLTAGES at namespace scope exactly as the simavr docs show.
//
// Why: simavr's header is written for C. Under avr-g++ 5.4 (a) its string tag uses a C99
// designator (.string = "...") that g++ rejects, and (b) its tags are namespace-scope `const`
// objects, which C++ gives internal linkage: nothing references them, so g++ drops them and the
// ELF has no .mmcu section at all (simavr then needs -m/-f on its command line, and without
// AVR_MCU_VOLTAGES the ADC divides by zero). Checked with avr-objdump -h on the image.
// Here the three macros are restated with positional initializers, extern "C" linkage (so
// `_mmcu` is the symbol that -Wl,--undefined=_mmcu keeps through --gc-sections) and `used`.
#pragma once

#ifdef __AVR__
#ifndef __AVR_MCU_SECTION_H__
#error "include <avr/avr_mcu_section.h> before simavr_mcu_tag.hpp"
#endif

#undef AVR_MCU_STRING
#undef AVR_MCU_LONG
#undef AVR_MCU

#define AVR_MCU_STRING(_tag, _str)                                               \
  extern "C" const struct avr_mmcu_string_t _##_tag _MMCU_ __attribute__((used)) = { \
      _tag, sizeof(struct avr_mmcu_string_t) - 2, _str}

#define AVR_MCU_LONG(_tag, _val)                                                  \
  extern "C" const struct avr_mmcu_long_t DO_CONCAT(DO_CONCAT(_, _tag), __LINE__) \
      _MMCU_ __attribute__((used)) = {_tag, sizeof(struct avr_mmcu_long_t) - 2, (_val)}

#define AVR_MCU(_speed, _name)                                                              \
  AVR_MCU_STRING(AVR_MMCU_TAG_NAME, _name);                                                \
  AVR_MCU_LONG(AVR_MMCU_TAG_FREQUENCY, _speed);                                            \
  extern "C" const uint8_t _mmcu[2] _MMCU_ __attribute__((used)) = {AVR_MMCU_TAG, 0}

#endif  // __AVR__

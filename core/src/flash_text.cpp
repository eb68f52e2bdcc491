// Flash texts (flash_text.hpp).
#include "thrustcal/flash_text.hpp"

namespace tc {

int8_t flashWordIndex(const char* words, const char* text) {
  int8_t index = 0;
  const char* p = words;
  for (;;) {
    const char* t = text;
    for (;;) {
      const uint8_t c = flashByte(p);
      if (c == '|' || c == 0) {
        if (*t == '\0') return index;
        break;
      }
      if (static_cast<uint8_t>(*t) != c) break;
      ++p;
      ++t;
    }
    while (flashByte(p) != '|' && flashByte(p) != 0) ++p;  // the rest of this word
    if (flashByte(p) == 0) return -1;
    ++p;
    ++index;
  }
}

}  // namespace tc

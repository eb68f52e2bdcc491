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

uint8_t flashWordCopy(const char* words, uint8_t index, char* out, uint8_t size) {
  const char* p = words;
  for (uint8_t i = 0; i < index; ++p) {
    if (flashByte(p) == 0) {
      out[0] = '\0';
      return 0;
    }
    if (flashByte(p) == '|') ++i;
  }
  uint8_t n = 0;
  while (n + 1 < size && flashByte(p) != 0 && flashByte(p) != '|') out[n++] = static_cast<char>(flashByte(p++));
  out[n] = '\0';
  return n;
}

}  // namespace tc

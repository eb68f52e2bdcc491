// Parameter rows: checks, the record's payload, values as text (param_table.hpp).
#include "thrustcal/param_table.hpp"

namespace tc {

namespace {

uint8_t wordCount(const char* words) {
  uint8_t n = 1;
  for (const char* p = words; flashByte(p) != 0; ++p) n = static_cast<uint8_t>(n + (flashByte(p) == '|'));
  return n;
}

int32_t readLe(const uint8_t* p, uint8_t bytes, bool is_signed) {
  uint32_t v = 0;
  for (uint8_t i = bytes; i-- > 0;) v = (v << 8) | p[i];
  if (is_signed && bytes < 4 && (v & (1ul << (8 * bytes - 1))) != 0) v |= ~((1ul << (8 * bytes)) - 1);
  return static_cast<int32_t>(v);
}

}  // namespace

bool paramAllowed(const ParamDef& d, int32_t value) {
  if (d.words != nullptr) return value >= 0 && value < wordCount(d.words);
  if (value == 0 && (d.flags & kParamZeroIsOff) != 0) return true;
  return value >= d.min && value <= d.max;
}

ParamCheck checkParams(const ParamDef* table, uint8_t rows, const int32_t* values) {
  ParamCheck c;
  for (uint8_t i = 0; i < rows; ++i) {
    const ParamDef d = paramRow(table, i);
    if (!paramAllowed(d, values[i])) {
      c.fault = ParamFault::kOutOfRange;
      c.row = i;
      return c;
    }
    if ((d.flags & kParamBelowNext) != 0 && i + 1 < rows && values[i + 1] != 0 && values[i] >= values[i + 1]) {
      c.fault = ParamFault::kNotBelowNext;
      c.row = i;
      return c;
    }
  }
  return c;
}

void defaultParams(const ParamDef* table, uint8_t rows, int32_t* values) {
  for (uint8_t i = 0; i < rows; ++i) values[i] = paramRow(table, i).def;
}

uint8_t paramPayloadBytes(const ParamDef* table, uint8_t rows) {
  uint16_t n = 0;
  for (uint8_t i = 0; i < rows; ++i) n = static_cast<uint16_t>(n + paramRow(table, i).bytes);
  return n > 255 ? 255 : static_cast<uint8_t>(n);
}

void encodeParams(const ParamDef* table, uint8_t rows, const int32_t* values, uint8_t* payload) {
  for (uint8_t i = 0; i < rows; ++i) {
    const uint8_t bytes = paramRow(table, i).bytes;
    const uint32_t v = static_cast<uint32_t>(values[i]);
    for (uint8_t b = 0; b < bytes; ++b) *payload++ = static_cast<uint8_t>(v >> (8 * b));
  }
}

ParamCheck decodeParams(const ParamDef* table, uint8_t rows, const uint8_t* payload, uint8_t length,
                        int32_t* values) {
  if (length != paramPayloadBytes(table, rows)) {
    defaultParams(table, rows, values);
    ParamCheck c;
    c.fault = ParamFault::kBadLength;
    return c;
  }
  for (uint8_t i = 0; i < rows; ++i) {
    const ParamDef d = paramRow(table, i);
    values[i] = readLe(payload, d.bytes, d.min < 0);
    payload += d.bytes;
  }
  return checkParams(table, rows, values);
}

int8_t findParam(const ParamDef* table, uint8_t rows, const char* name) {
  for (uint8_t i = 0; i < rows; ++i) {
    const ParamDef d = paramRow(table, i);
    const char* p = d.name;
    const char* t = name;
    while (*t != '\0' && static_cast<uint8_t>(*t) == flashByte(p)) {
      ++t;
      ++p;
    }
    if (*t == '\0' && flashByte(p) == 0) return static_cast<int8_t>(i);
  }
  return -1;
}

uint8_t formatParamValue(const ParamDef& d, int32_t value, char* out) {
  if (d.words != nullptr && value >= 0 && value < wordCount(d.words))
    return flashWordCopy(d.words, static_cast<uint8_t>(value), out, kParamTextMax);
  char digits[12];
  uint8_t n = 0;
  uint32_t mag = value < 0 ? 0u - static_cast<uint32_t>(value) : static_cast<uint32_t>(value);
  do {
    digits[n++] = static_cast<char>('0' + mag % 10u);
    mag /= 10u;
  } while (mag != 0 || n <= d.decimals);  // at least one digit before the point
  uint8_t len = 0;
  if (value < 0) out[len++] = '-';
  while (n > 0) {
    if (n == d.decimals) out[len++] = '.';
    out[len++] = digits[--n];
  }
  out[len] = '\0';
  return len;
}

ParamParse parseParamValue(const ParamDef& d, const char* text, int32_t& value) {
  if (d.words != nullptr) {
    const int8_t index = flashWordIndex(d.words, text);
    if (index < 0) return ParamParse::kNotAWord;
    value = index;
    return ParamParse::kOk;
  }
  const char* p = text;
  const bool negative = *p == '-';
  if (negative) ++p;
  uint32_t mag = 0;
  uint8_t digits = 0, decimals = 0;
  bool point = false;
  for (; *p != '\0'; ++p) {
    if (*p == '.' && !point) {
      point = true;
      continue;
    }
    if (*p < '0' || *p > '9') return ParamParse::kNotANumber;
    if (point && ++decimals > d.decimals) return ParamParse::kNotANumber;
    if (mag > 200000000ul) return ParamParse::kNotAllowed;  // beyond any range a table holds
    mag = mag * 10u + static_cast<uint32_t>(*p - '0');
    ++digits;
  }
  if (digits == 0 || (point && decimals == 0)) return ParamParse::kNotANumber;
  for (; decimals < d.decimals; ++decimals) {
    if (mag > 200000000ul) return ParamParse::kNotAllowed;
    mag *= 10u;
  }
  value = negative ? -static_cast<int32_t>(mag) : static_cast<int32_t>(mag);
  return paramAllowed(d, value) ? ParamParse::kOk : ParamParse::kNotAllowed;
}

}  // namespace tc

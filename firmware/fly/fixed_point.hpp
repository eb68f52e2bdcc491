// Fixed point for fly's frame path: a gain is a 16-bit mantissa and a power of two, and a value
// times a gain takes two 16 x 16 -> 32 products (the AVR's MUL) and shifts instead of float
// arithmetic (on the AVR a float product or sum costs a hundred or more cycles, and so does each
// conversion between float and integer). Gains are made from floats when a setting changes,
// never in the frame.
//
//   applyGain(v, g) = v * m / 2^s, rounded to the nearest (halves up), exactly, for any int32 v
//   whose result fits an int32 (fly's values stay far inside: the units in estimator.hpp).
#pragma once
#include <stdint.h>

// The helpers below are a few instructions each once inlined (a constant gain folds its shifts
// away); avr-gcc at -Os would call them instead, which costs more than their bodies.
#define FLY_INLINE __attribute__((always_inline)) inline

namespace fly {

struct Gain {
  int16_t m = 0;  // mantissa
  uint8_t s = 0;  // right shift, 0..kMaxGainShift
};

constexpr uint8_t kMaxGainShift = 46;  // keeps the rounding term and a 2^30 product within an int32

// The gain nearest `g` with |m| <= 32767 and the largest shift that allows it (the most
// significant bits); 0 for |g| below 2^-47 (and NaN), saturated at |m| 32767 with s 0 for
// |g| >= 32767.5. constexpr: constant gains are made by the compiler.
constexpr Gain gainOf(float g) {
  const float magnitude = g < 0 ? -g : g;
  Gain out;
  if (!(magnitude > 0.0f)) return out;
  float scaled = magnitude;  // magnitude * 2^s, exact: powers of two
  while (out.s + 8 <= kMaxGainShift && scaled * 256.0f < 32767.5f) {
    scaled *= 256.0f;
    out.s = static_cast<uint8_t>(out.s + 8);
  }
  while (out.s < kMaxGainShift && scaled * 2.0f < 32767.5f) {
    scaled *= 2.0f;
    ++out.s;
  }
  const int16_t m = scaled >= 32767.5f ? 32767 : static_cast<int16_t>(scaled + 0.5f);
  out.m = g < 0 ? static_cast<int16_t>(-m) : m;
  return out;
}
// The float a gain stands for (status, tests).
float gainValue(const Gain& g);

// v >> n (arithmetic) and v << n for n in 0..31 as at most five constant shifts: the AVR has
// no barrel shifter, and gcc shifts a 32-bit value by a variable count one bit per loop turn
// (~6 cycles a bit), by 16 or 8 with register moves. Bit for bit the same as the shift.
FLY_INLINE int32_t shiftRight(int32_t v, uint8_t n) {
  if (n & 16) v >>= 16;
  if (n & 8) v >>= 8;
  if (n & 4) v >>= 4;
  if (n & 2) v >>= 2;
  if (n & 1) v >>= 1;
  return v;
}
FLY_INLINE uint32_t shiftLeft(uint32_t v, uint8_t n) {
  if (n & 16) v <<= 16;
  if (n & 8) v <<= 8;
  if (n & 4) v <<= 4;
  if (n & 2) v <<= 2;
  if (n & 1) v <<= 1;
  return v;
}
// (v + 2^(n-1)) >> n, n in 1..32, without the sum: floor((floor(v / 2^(n-1)) + 1) / 2) is the
// same integer.
FLY_INLINE int32_t roundedShiftRight(int32_t v, uint8_t n) { return (shiftRight(v, static_cast<uint8_t>(n - 1)) + 1) >> 1; }

// v * g.m / 2^g.s, rounded half up: v = hi * 2^16 + lo (hi signed, lo unsigned), two 16 x 16
// products summed with the 2^16 weight folded into the shift.
FLY_INLINE int32_t applyGain(int32_t v, const Gain& g) {
  const int32_t m = g.m;
  const int32_t hi = static_cast<int32_t>(static_cast<int16_t>(v >> 16)) * m;
  const int32_t lo = static_cast<int32_t>(static_cast<uint16_t>(v)) * m;
  if (g.s >= 17) return roundedShiftRight(hi + (lo >> 16), static_cast<uint8_t>(g.s - 16));
  if (g.s == 16) return hi + ((lo + (static_cast<int32_t>(1) << 15)) >> 16);
  if (g.s == 0) return static_cast<int32_t>(static_cast<uint32_t>(hi) << 16) + lo;
  return static_cast<int32_t>(shiftLeft(static_cast<uint32_t>(hi), static_cast<uint8_t>(16 - g.s))) +
         roundedShiftRight(lo, g.s);
}

// A float to the nearest integer (halves away from zero), saturated to int32: settings and
// slow jobs only.
int32_t roundToInt32(float v);

}  // namespace fly

// Fixed point for fly's frame path (fixed_point.hpp).
#include "fixed_point.hpp"

namespace fly {

float gainValue(const Gain& g) {
  float v = g.m;
  for (uint8_t i = 0; i < g.s; ++i) v *= 0.5f;
  return v;
}

int32_t roundToInt32(float v) {
  if (v >= 2147483648.0f) return 2147483647;
  if (v <= -2147483648.0f) return -2147483647 - 1;
  return static_cast<int32_t>(v < 0 ? v - 0.5f : v + 0.5f);
}

}  // namespace fly

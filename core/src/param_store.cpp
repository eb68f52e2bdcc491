// Saved-parameter record <-> bytes (layout in param_store.hpp).
#include "thrustcal/param_store.hpp"

namespace tc {

bool ParamsRecord::samePayload(const ParamsRecord& o) const {
  if (layout != o.layout || length != o.length) return false;
  for (uint8_t i = 0; i < length; ++i)
    if (payload[i] != o.payload[i]) return false;
  return true;
}

void serializeParams(const ParamsRecord& r, uint16_t sequence, uint8_t* image) {
  image[0] = kParamsKind;
  image[1] = kParamsMagic;
  image[2] = static_cast<uint8_t>(sequence & 0xFF);
  image[3] = static_cast<uint8_t>(sequence >> 8);
  image[4] = r.layout;
  image[5] = r.length;
  for (uint8_t i = 0; i < r.length; ++i) image[kParamsHeaderBytes + i] = r.payload[i];
  const uint16_t end = static_cast<uint16_t>(kParamsHeaderBytes + r.length);
  const uint16_t crc = crc16CcittFalse(image, end);
  image[end] = static_cast<uint8_t>(crc & 0xFF);
  image[end + 1] = static_cast<uint8_t>(crc >> 8);
}

}  // namespace tc

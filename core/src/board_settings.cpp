// Board settings record <-> BoardSettings (layout in board_settings.hpp), byte by byte.
#include "thrustcal/board_settings.hpp"

namespace tc {

namespace {

void putU32(uint8_t* p, uint32_t v) {
  for (uint8_t i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}

uint32_t getU32(const uint8_t* p) {
  uint32_t v = 0;
  for (uint8_t i = 4; i-- > 0;) v = (v << 8) | p[i];
  return v;
}

}  // namespace

uint16_t BoardSettings::fullScaleMv() const {
  if (divider_bottom_ohm == 0) return 0;
  return dividerFullScaleMillivolts(divider_top_ohm, divider_bottom_ohm, kAdcReferenceMv);
}

bool BoardSettings::isValid() const {
  if (divider_bottom_ohm < kDividerMinBottomOhm || divider_bottom_ohm > kDividerMaxOhm ||
      divider_top_ohm > kDividerMaxOhm)
    return false;
  const uint16_t fs = fullScaleMv();
  return fs >= kAdcReferenceMv && fs <= kMaxFullScaleMv;
}

BatteryConfig BoardSettings::batteryConfig() const {
  BatteryConfig c;
  const uint16_t fs = isValid() ? fullScaleMv() : kDefaultFullScaleMv;
  c.full_scale_mv = fs;
  c.min_sane_mv = kPackMinMv;
  // A reading at the full scale is the ADC's rail: the pack may be above the monitor's range.
  c.max_sane_mv = fs <= kPackMaxMv ? static_cast<uint16_t>(fs - 1u) : kPackMaxMv;
  return c;
}

RecordLimits BoardSettings::recordLimits() const {
  RecordLimits l;
  l.monitor_full_scale_mv = isValid() ? fullScaleMv() : kDefaultFullScaleMv;
  return l;
}

void serializeSettings(const BoardSettings& s, uint16_t sequence, uint8_t* image) {
  const bool bench = s.bench.isPresent();
  image[0] = bench ? kSettingsKindBench : kSettingsKind;
  image[1] = kSettingsMagic;
  image[2] = static_cast<uint8_t>(sequence & 0xFF);
  image[3] = static_cast<uint8_t>(sequence >> 8);
  putU32(image + 4, s.divider_top_ohm);
  putU32(image + 8, s.divider_bottom_ohm);
  if (bench) {
    image[12] = s.bench.stages;
    image[13] = static_cast<uint8_t>(s.bench.tau_01ms & 0xFF);
    image[14] = static_cast<uint8_t>(s.bench.tau_01ms >> 8);
  }
  const uint16_t crc_at = static_cast<uint16_t>(settingsLength(image[0]) - 2);
  const uint16_t crc = crc16CcittFalse(image, crc_at);
  image[crc_at] = static_cast<uint8_t>(crc & 0xFF);
  image[crc_at + 1] = static_cast<uint8_t>(crc >> 8);
}

DecodeStatus parseSettings(const uint8_t* image, BoardSettings& out, uint16_t& sequence) {
  out = BoardSettings();
  sequence = 0;
  if (image[0] == 0xFF) return DecodeStatus::kErased;
  const bool bench = image[0] == kSettingsKindBench;
  if ((!bench && image[0] != kSettingsKind) || image[1] != kSettingsMagic) return DecodeStatus::kBadVersion;
  const uint16_t crc_at = static_cast<uint16_t>(settingsLength(image[0]) - 2);
  const uint16_t crc = static_cast<uint16_t>(image[crc_at] | (static_cast<uint16_t>(image[crc_at + 1]) << 8));
  if (crc16CcittFalse(image, crc_at) != crc) return DecodeStatus::kBadCrc;
  BoardSettings s;
  s.divider_top_ohm = getU32(image + 4);
  s.divider_bottom_ohm = getU32(image + 8);
  if (bench) {
    s.bench.stages = image[12];
    s.bench.tau_01ms = static_cast<uint16_t>(image[13] | (static_cast<uint16_t>(image[14]) << 8));
    if (!s.bench.isValid()) return DecodeStatus::kBadContent;
  }
  if (!s.isValid()) return DecodeStatus::kBadContent;
  out = s;
  sequence = static_cast<uint16_t>(image[2] | (static_cast<uint16_t>(image[3]) << 8));
  return DecodeStatus::kOk;
}

}  // namespace tc

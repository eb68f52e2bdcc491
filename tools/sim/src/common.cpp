#include <fmt/format.h>

#include <cstdio>
#include <stdexcept>

#include "sim/scenarios.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/record_v2.hpp"

namespace sim {
namespace {

// EEPROM storage over a host image, for the firmware's own codec.
struct ReadOnlyImage {
  static const std::vector<uint8_t>* image;
  static uint8_t readByte(uint16_t addr) { return (*image)[addr]; }
  static void updateByte(uint16_t, uint8_t) {}  // decode only
};
const std::vector<uint8_t>* ReadOnlyImage::image = nullptr;

void checkImageAndSlot(const std::vector<uint8_t>& eeprom, int slot) {
  if (eeprom.size() < static_cast<std::size_t>(tc::kRecordBytes) * tc::kMotorSlots)
    throw std::invalid_argument(
        fmt::format("EEPROM image has {} bytes, need {}", eeprom.size(),
                    tc::kRecordBytes * tc::kMotorSlots));
  if (slot < 0 || slot >= tc::kMotorSlots)
    throw std::invalid_argument(fmt::format("slot {} is not 0..3", slot));
}

}  // namespace

std::string decodeSlot(const std::vector<uint8_t>& eeprom, int slot, tc::MotorCalibration& out) {
  checkImageAndSlot(eeprom, slot);
  ReadOnlyImage::image = &eeprom;
  const tc::DecodeStatus status = tc::readRecord<ReadOnlyImage>(static_cast<uint8_t>(slot), out);
  ReadOnlyImage::image = nullptr;
  return tc::decodeStatusText(status);
}

std::string decodeSlotV2(const std::vector<uint8_t>& eeprom, int slot, tc::ModelV2& out) {
  checkImageAndSlot(eeprom, slot);
  ReadOnlyImage::image = &eeprom;
  const tc::RecordV2Read r = tc::readModelV2<ReadOnlyImage>(static_cast<uint8_t>(slot), out);
  ReadOnlyImage::image = nullptr;
  return tc::decodeStatusText(r.status);
}

void copySlot(std::vector<uint8_t>& eeprom, int from, int to) {
  if (from == to) return;
  for (uint16_t i = 0; i < tc::kRecordBytes; ++i)
    eeprom.at(tc::slotAddress(static_cast<uint8_t>(to)) + i) =
        eeprom.at(tc::slotAddress(static_cast<uint8_t>(from)) + i);
}

plant::ActuatorParams motorForSeed(const std::string& preset, uint64_t seed, double variation) {
  return plant::makeVaried(plant::presetParams(preset), seed, variation);
}

void stderrProgress(const std::string& line) {
  std::fprintf(stderr, "sim: %s\n", line.c_str());
  std::fflush(stderr);
}

}  // namespace sim

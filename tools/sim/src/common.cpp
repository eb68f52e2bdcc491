#include <fmt/format.h>

#include <cstdio>
#include <stdexcept>

#include "sim/scenarios.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/eeprom_image.hpp"
#include "thrustcal/record_v2.hpp"

namespace sim {
namespace {

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
  const tc::EepromImage::Use use(eeprom);
  return tc::decodeStatusText(tc::readRecord<tc::EepromImage>(static_cast<uint8_t>(slot), out));
}

std::string decodeSlotV2(const std::vector<uint8_t>& eeprom, int slot, tc::ModelV2& out) {
  checkImageAndSlot(eeprom, slot);
  const tc::EepromImage::Use use(eeprom);
  return tc::decodeStatusText(tc::readModelV2<tc::EepromImage>(static_cast<uint8_t>(slot), out).status);
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

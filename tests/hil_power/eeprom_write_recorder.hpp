// Every physical EEPROM byte write of the simulated ATmega2560, in order: the power-cut tests
// replay the first k of them onto the image before a store to get what a power loss after
// write k leaves.
#pragma once
#include <simavr/sim_avr.h>
#include <simavr/sim_io.h>

#include <cstdint>
#include <vector>

#include "sim/board.hpp"

namespace hil_power {

struct EepromWrite {
  uint16_t addr;
  uint8_t value;
};

// ATmega2560 data-space addresses (avr/iomxx0_1.h: EECR 0x1F, EEDR 0x20, EEAR 0x21 in I/O space).
constexpr avr_io_addr_t kEecr = 0x3F, kEedr = 0x40, kEearl = 0x41, kEearh = 0x42;
constexpr uint8_t kEepeBit = 1u << 1;

// Records every EEPE strobe (one physical byte write: address EEAR, value EEDR) while
// `recording`. simavr's EEPROM module keeps its own handler on EECR: registering a second one
// makes simavr share the address (both are called, the EEPROM module's first). The sim harness
// has no such hook.
class EepromWriteRecorder {
 public:
  explicit EepromWriteRecorder(sim::Board& board) {
    avr_register_io_write(board.avr(), kEecr, &EepromWriteRecorder::onEecr, this);
  }
  bool recording = false;
  std::vector<EepromWrite> writes;

 private:
  static void onEecr(avr_t* avr, avr_io_addr_t, uint8_t v, void* param) {
    auto* self = static_cast<EepromWriteRecorder*>(param);
    if (!self->recording || (v & kEepeBit) == 0) return;
    const uint16_t addr = static_cast<uint16_t>(avr->data[kEearl] | (avr->data[kEearh] << 8));
    self->writes.push_back({addr, avr->data[kEedr]});
  }
};

}  // namespace hil_power

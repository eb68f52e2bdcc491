// Taking an I/O register over from simavr 1.6, as the board's chip-true peripherals do
// (sim/ports.hpp, sim/ext_int.hpp, sim/timers.hpp; sim/twi.hpp does the same for the TWI):
// simavr refuses to register a second handler on an address, but its io[] table is public.
#pragma once
#include <cstdint>

extern "C" {
#include <simavr/sim_avr.h>
}

namespace sim {

inline void takeIoWrite(avr_t* avr, uint16_t data_addr, avr_io_write_t write, void* param) {
  auto& io = avr->io[AVR_DATA_TO_IO(data_addr)];
  io.w.c = write;
  io.w.param = param;
}

inline void takeIoRead(avr_t* avr, uint16_t data_addr, avr_io_read_t read, void* param) {
  auto& io = avr->io[AVR_DATA_TO_IO(data_addr)];
  io.r.c = read;
  io.r.param = param;
}

// Forgets the handlers registered with `param` on the address (a peripheral going away).
inline void releaseIo(avr_t* avr, uint16_t data_addr, const void* param) {
  auto& io = avr->io[AVR_DATA_TO_IO(data_addr)];
  if (io.w.param == param) io.w = {nullptr, nullptr};
  if (io.r.param == param) io.r = {nullptr, nullptr};
}

// The flags a write to a "write one to clear" flag register clears. SBI and CBI act on their
// one bit on the chip ("the CBI and SBI instructions will only operate on the specified bit,
// and can therefore be used on registers containing such Status Flags"), while simavr writes
// the whole register back: SBI clears only its bit, CBI clears nothing. The instruction is the
// one at avr->pc, which simavr executes while it calls the register's handler.
inline uint8_t flagsWrittenOne(const avr_t* avr, uint16_t data_addr, uint8_t value) {
  const uint16_t opcode =
      static_cast<uint16_t>(avr->flash[avr->pc] | (avr->flash[avr->pc + 1] << 8));
  const bool bit_instruction = (opcode & 0xFD00) == 0x9800;  // CBI 0x98xx, SBI 0x9Axx
  if (bit_instruction && data_addr < 0x40 && ((opcode >> 3) & 0x1F) == data_addr - 0x20)
    return (opcode & 0x0200) ? static_cast<uint8_t>(1u << (opcode & 7)) : 0;
  return value;
}

}  // namespace sim

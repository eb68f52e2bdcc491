// The longest time without a watchdog kick (sim/watchdog_gaps.hpp).
#include "sim/watchdog_gaps.hpp"

#include <fmt/format.h>

#include <stdexcept>

extern "C" {
#include <simavr/sim_avr.h>
}

namespace sim {

namespace {
constexpr uint8_t kWdrLow = 0xA8, kWdrHigh = 0x95;  // `wdr`: 0x95A8, stored little-endian
constexpr uint32_t kLeafBytes = 4;  // `wdr; ret`: a kick function (hal::Watchdog::kick)
constexpr uint16_t kSpl = 0x5D, kSph = 0x5E;  // the stack pointer (data addresses)
}  // namespace

KickGapMeter::KickGapMeter(Board& board, const std::string& elf_path) : board_(board) {
  // Only inside functions, on instruction boundaries (even addresses): data in flash (strings,
  // tables) never matches by accident.
  for (const FlashSymbol& s : flashSymbols(elf_path)) {
    if (!s.function || s.size < 2) continue;
    const std::vector<uint8_t> code = board_.flash(s.address, s.size);
    for (std::size_t i = 0; i + 1 < code.size(); i += 2)
      if (code[i] == kWdrLow && code[i + 1] == kWdrHigh)
        sites_.push_back({static_cast<uint32_t>(s.address + i), s.name, s.size <= kLeafBytes});
  }
  symbols_ = flashSymbols(elf_path);
  if (sites_.empty()) throw std::runtime_error(fmt::format("{}: no wdr instruction in any function", elf_path));
  for (std::size_t i = 0; i < sites_.size(); ++i)
    board_.watchPc(sites_[i].address, [this, i](uint64_t cycle) { onKick(i, cycle); });
  board_.addResetListener([this](uint64_t) { restart(); });
  restart();
}

void KickGapMeter::restart() {
  last_cycle_ = board_.cycle();
  seen_ = false;
  longest_cycles_ = 0;
  kicks_ = 0;
}

// Where a kick came from: its own address, or for a kick function (`wdr; ret`, called) its
// caller's, from the return address on the stack (three bytes on the ATmega2560, high first).
uint32_t KickGapMeter::whereNow(std::size_t site) const {
  if (!sites_[site].leaf) return sites_[site].address;
  const avr_t* avr = board_.avr();
  const uint16_t sp = static_cast<uint16_t>(avr->data[kSpl] | (avr->data[kSph] << 8));
  const uint32_t word = (static_cast<uint32_t>(avr->data[sp + 1]) << 16) |
                        (static_cast<uint32_t>(avr->data[sp + 2]) << 8) | avr->data[sp + 3];
  return 2 * word;
}

void KickGapMeter::onKick(std::size_t site, uint64_t cycle) {
  ++kicks_;
  const uint32_t where = whereNow(site);
  if (seen_ && cycle - last_cycle_ > longest_cycles_) {
    longest_cycles_ = cycle - last_cycle_;
    longest_from_ = last_where_;
    longest_to_ = where;
  }
  seen_ = true;
  last_cycle_ = cycle;
  last_where_ = where;
}

// The longest gap: the one still open (from the last kick, or restart(), to now) when it is
// longer than every closed one.
KickGapMeter::Gap KickGapMeter::longest() const {
  const uint64_t open = board_.cycle() - last_cycle_;
  if (open > longest_cycles_) return {open, seen_ ? symbolAt(symbols_, last_where_) : "(restart)", "(now)"};
  if (longest_cycles_ == 0) return {0, "(none)", "(none)"};
  return {longest_cycles_, symbolAt(symbols_, longest_from_), symbolAt(symbols_, longest_to_)};
}

double KickGapMeter::longestMs() const { return 1000.0 * cyclesToSeconds(longest().cycles); }
std::string KickGapMeter::longestFrom() const { return longest().from; }
std::string KickGapMeter::longestTo() const { return longest().to; }

}  // namespace sim

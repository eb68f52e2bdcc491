// How long a firmware image runs without kicking its watchdog: every `wdr` instruction in the
// image's functions is watched (Board::watchPc), and the longest stretch of simulated time
// between two of them is kept, with the functions the two kicks were in. The watchdog resets
// the chip after 64 ms without a kick (WDTO_60MS in simavr; ~70-75 ms on a chip whose
// oscillator runs slow), so this is the margin a long piece of work leaves (docs/safety.md,
// "Watchdog headroom").
//
// Watching the program counter takes the board off its fast path (a check per instruction):
// meant for the safety tests and the bench, not for every simulation. The board keeps the
// watches (it has no way to drop one): make the meter after the board and do not run the board
// once the meter is gone.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "sim/board.hpp"
#include "sim/elf_symbols.hpp"

namespace sim {

class KickGapMeter {
 public:
  // The most any piece of work may run between two kicks: half the 64 ms time-out, so a chip
  // whose watchdog oscillator runs fast, or work that grows, still has a margin (docs/safety.md).
  static constexpr double kHeadroomTargetMs = 32.0;

  // Watches every `wdr` in `elf_path`'s functions on `board` (which runs that image).
  // Throws std::runtime_error when the image has none.
  KickGapMeter(Board& board, const std::string& elf_path);
  KickGapMeter(const KickGapMeter&) = delete;
  KickGapMeter& operator=(const KickGapMeter&) = delete;

  // Forgets what was measured; the next gap counts from now (call it once the image has
  // started its watchdog, e.g. at its first prompt). A reset of the board does the same.
  void restart();

  // The longest gap measured since restart(), and where: the function of the kick that
  // began it and of the kick that ended it (for a call of hal::Watchdog::kick, its caller). The gap still open (from the last kick to now)
  // counts too.
  double longestMs() const;
  std::string longestFrom() const;
  std::string longestTo() const;
  std::size_t kickSites() const { return sites_.size(); }
  uint64_t kicks() const { return kicks_; }

 private:
  struct Site {
    uint32_t address;
    std::string function;
    bool leaf;  // a kick function: the kick is its caller's
  };
  struct Gap {
    uint64_t cycles;
    std::string from, to;
  };
  Gap longest() const;
  uint32_t whereNow(std::size_t site) const;
  void onKick(std::size_t site, uint64_t cycle);

  Board& board_;
  std::vector<Site> sites_;
  std::vector<FlashSymbol> symbols_;
  uint64_t last_cycle_ = 0;
  uint32_t last_where_ = 0;  // program address of the last kick (its caller's for a kick function)
  bool seen_ = false;        // a kick since restart()
  uint64_t longest_cycles_ = 0;
  uint32_t longest_from_ = 0, longest_to_ = 0;  // 0 cycles: no gap between two kicks yet
  uint64_t kicks_ = 0;
};

}  // namespace sim

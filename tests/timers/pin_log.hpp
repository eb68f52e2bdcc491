// Shared by the timer tests: the images built here, a record of pin edges with the cycle each
// happened at (sim::Ports::changeCycle: a compare output's timer tick), and pin changes driven
// from outside at exact cycles.
#pragma once
#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "sim/board.hpp"
#include "sim/pin_names.hpp"
#include "sim/ports.hpp"

extern "C" {
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_irq.h>
}

namespace timers_test {

// The image `name` (tests/timers/firmware/NAME.c), or "" when avr-gcc was not found.
inline std::string image(const std::string& name) {
  const std::string dir = TIMER_ELF_DIR;
  return dir.empty() ? "" : dir + "/" + name + ".elf";
}

#define TIMERS_REQUIRE_IMAGES() \
  if (std::string(TIMER_ELF_DIR).empty()) GTEST_SKIP() << "avr-gcc not found: no timer test images"

struct Edge {
  uint64_t cycle;
  bool level;
};

// Every edge of the named pins ("D6", "PE7") from now on.
class PinLog {
 public:
  PinLog(sim::Board& board, const std::vector<std::string>& pins) : board_(board) {
    for (const std::string& name : pins) {
      auto hook = std::make_unique<Hook>();
      hook->log = this;
      hook->name = name;
      const hal::MegaPin pin = sim::parseMegaPin(name);
      hook->irq = board_.ports().pinIrq(pin.port, pin.bit);
      avr_irq_register_notify(hook->irq, &PinLog::onEdge, hook.get());
      edges_[name];
      hooks_.push_back(std::move(hook));
    }
  }
  ~PinLog() {
    for (auto& h : hooks_) avr_irq_unregister_notify(h->irq, &PinLog::onEdge, h.get());
  }
  const std::vector<Edge>& edges(const std::string& pin) const { return edges_.at(pin); }
  // Cycles between consecutive rising edges, and the high time after each rise.
  std::vector<int64_t> periods(const std::string& pin) const {
    std::vector<int64_t> out;
    const std::vector<uint64_t> r = rises(pin);
    for (std::size_t i = 1; i < r.size(); ++i) out.push_back(static_cast<int64_t>(r[i] - r[i - 1]));
    return out;
  }
  std::vector<int64_t> highs(const std::string& pin) const {
    std::vector<int64_t> out;
    const auto& e = edges(pin);
    for (std::size_t i = 1; i < e.size(); ++i)
      if (e[i - 1].level && !e[i].level) out.push_back(static_cast<int64_t>(e[i].cycle - e[i - 1].cycle));
    return out;
  }
  // Cycles between consecutive edges of either direction.
  std::vector<int64_t> intervals(const std::string& pin) const {
    std::vector<int64_t> out;
    const auto& e = edges(pin);
    for (std::size_t i = 1; i < e.size(); ++i) out.push_back(static_cast<int64_t>(e[i].cycle - e[i - 1].cycle));
    return out;
  }

 private:
  struct Hook {
    PinLog* log;
    std::string name;
    avr_irq_t* irq;
  };
  std::vector<uint64_t> rises(const std::string& pin) const {
    std::vector<uint64_t> r;
    for (const Edge& e : edges(pin))
      if (e.level) r.push_back(e.cycle);
    return r;
  }
  static void onEdge(avr_irq_t* irq, uint32_t value, void* param) {
    auto* h = static_cast<Hook*>(param);
    if ((irq->value != 0) == (value != 0)) return;
    h->log->edges_[h->name].push_back(Edge{h->log->board_.ports().changeCycle(), value != 0});
  }
  sim::Board& board_;
  std::vector<std::unique_ptr<Hook>> hooks_;
  std::map<std::string, std::vector<Edge>> edges_;
};

// The last `n` values of v (all of them if fewer).
inline std::vector<int64_t> last(const std::vector<int64_t>& v, std::size_t n) {
  return std::vector<int64_t>(v.size() > n ? v.end() - static_cast<std::ptrdiff_t>(n) : v.begin(), v.end());
}

// Drives a pin from outside at exact cycles (as a receiver or a sensor would), with a cycle
// timer per change: the board sees each change at its cycle.
class PinDriver {
 public:
  PinDriver(sim::Board& board, const std::string& pin) : board_(board), pin_(sim::parseMegaPin(pin)) {}
  ~PinDriver() { avr_cycle_timer_cancel(board_.avr(), &PinDriver::onTime, this); }
  // Levels at absolute cycles (ascending, all in the future).
  void schedule(std::vector<std::pair<uint64_t, bool>> changes) {
    pending_ = std::move(changes);
    next_ = 0;
    arm();
  }
  void setNow(bool level) { board_.ports().setInput(pin_.port, pin_.bit, level, board_.cycle()); }
  // The board's view of the pin's counter at each change: filled by a callback if set.
  std::function<void(uint64_t when, uint64_t now)> on_change;

 private:
  void arm() {
    if (next_ < pending_.size())
      avr_cycle_timer_register(board_.avr(), pending_[next_].first - board_.cycle(), &PinDriver::onTime, this);
  }
  static uint64_t onTime(avr_t* avr, uint64_t when, void* param) {
    auto* self = static_cast<PinDriver*>(param);
    const auto change = self->pending_[self->next_++];
    self->board_.ports().setInput(self->pin_.port, self->pin_.bit, change.second, when);
    if (self->on_change) self->on_change(when, avr->cycle);
    if (self->next_ >= self->pending_.size()) return 0;
    return self->pending_[self->next_].first;
  }
  sim::Board& board_;
  hal::MegaPin pin_;
  std::vector<std::pair<uint64_t, bool>> pending_;
  std::size_t next_ = 0;
};

}  // namespace timers_test

// The RC receiver part: see sim/rc_receiver.hpp.
#include "sim/rc_receiver.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sim/board.hpp"
#include "sim/ports.hpp"

extern "C" {
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_irq.h>
}

namespace sim {
namespace {

const char* kRcIrqNames[kRcChannels] = {">rc.line0", ">rc.line1", ">rc.line2", ">rc.line3",
                                      ">rc.line4", ">rc.line5", ">rc.line6", ">rc.line7"};

uint64_t usToCycles(double us) { return static_cast<uint64_t>(std::llround(us * (kCpuHz / 1e6))); }

uint8_t idleLevel(const RcPart& p) { return p.signal == RcSignal::kPpm ? 1 : 0; }

// Line `line` goes to `level` at `cycle` (<= now).
void drive(RcPart& p, int line, uint8_t level, uint64_t cycle) {
  p.level[line] = level;
  avr_raise_irq(p.irq + line, level);
  if (p.ports) p.ports->setInput(p.pins[line].port, p.pins[line].bit, level != 0, cycle);
}

void addEdge(RcPart& p, uint64_t cycle, int line, uint8_t level) {
  p.edges[p.edge_count++] = RcPart::Edge{cycle, static_cast<uint8_t>(line), level};
}

// The edges of the frame that starts at `start` (the values in p.frame), in time order.
void planFrame(RcPart& p, uint64_t start) {
  p.frame_start = start;
  p.edge_count = p.edge_next = 0;
  const int channels = p.signal == RcSignal::kPpm ? kRcChannels : p.lines;
  std::array<uint64_t, kRcChannels> width{};
  uint64_t sum = 0;
  for (int i = 0; i < channels; ++i) sum += width[i] = usToCycles(p.frame.us[i]);
  if (p.signal == RcSignal::kPpm) {
    p.frame_cycles = std::max(usToCycles(kPpmFrameUs), sum + usToCycles(kPpmMinSyncUs));
    if (!p.frame.on) return;
    uint64_t t = start;
    for (int i = 0; i <= channels; ++i) {  // a separator before each channel and after the last
      addEdge(p, t, 0, 0);
      addEdge(p, t + usToCycles(kPpmSeparatorUs), 0, 1);
      if (i < channels) t += width[i];
    }
  } else {
    p.frame_cycles = std::max(usToCycles(kPwmFrameUs), sum + usToCycles(kPwmMinGapUs));
    if (!p.frame.on) return;
    uint64_t t = start;
    for (int i = 0; i < channels; ++i) {
      addEdge(p, t, i, 1);
      t += width[i];
      addEdge(p, t, i, 0);  // the next channel rises in this cycle, after this fall
    }
  }
  ++p.frames;
}

// Puts every edge due by `now` on its pin, starts the next frame when it is due; returns the
// cycle of the next thing to do.
uint64_t service(RcPart& p, uint64_t now) {
  for (;;) {
    while (p.edge_next < p.edge_count && p.edges[p.edge_next].cycle <= now) {
      const RcPart::Edge& e = p.edges[p.edge_next++];
      drive(p, e.line, e.level, e.cycle);
    }
    const uint64_t frame_end = p.frame_start + p.frame_cycles;
    if (frame_end > now) return p.edge_next < p.edge_count ? p.edges[p.edge_next].cycle : frame_end;
    p.frame = p.next;  // latched at the frame's start
    planFrame(p, frame_end);
  }
}

uint64_t onClock(avr_t*, uint64_t when, void* param) { return service(*static_cast<RcPart*>(param), when); }

}  // namespace

const char* rcSignalName(RcSignal s) { return s == RcSignal::kPpm ? "ppm" : "pwm"; }

void rc_receiver_init(avr_t* avr, RcPart& part, RcSignal signal, int lines) {
  const int most = signal == RcSignal::kPpm ? 1 : kRcChannels;
  if (lines < 1 || lines > most)
    throw std::invalid_argument(fmt::format("an RC receiver's {} output has 1..{} pins, not {}",
                                            rcSignalName(signal), most, lines));
  part.avr = avr;
  part.signal = signal;
  part.lines = lines;
  part.irq = avr_alloc_irq(&avr->irq_pool, 0, static_cast<uint32_t>(lines), kRcIrqNames);
  for (int i = 0; i < lines; ++i) part.level[i] = idleLevel(part);
  part.frame = part.next = RcFrame{};
  planFrame(part, avr->cycle);  // no signal yet: an empty frame keeps the clock
  avr_cycle_timer_register(avr, part.frame_cycles, onClock, &part);
}

void rc_receiver_connect(RcPart& part, Ports& ports, const std::vector<hal::MegaPin>& pins) {
  if (static_cast<int>(pins.size()) != part.lines)
    throw std::invalid_argument(fmt::format("an RC receiver with {} lines wired to {} pins", part.lines, pins.size()));
  std::copy(pins.begin(), pins.end(), part.pins.begin());
  part.ports = &ports;
  for (int i = 0; i < part.lines; ++i) drive(part, i, part.level[i], part.avr->cycle);
}

void rc_receiver_set(RcPart& part, const double* us, int count) {
  if (count < 1 || count > kRcChannels)
    throw std::invalid_argument(fmt::format("give 1..{} channel values, not {}", kRcChannels, count));
  for (int i = 0; i < count; ++i)
    if (!(us[i] >= kRcChannelMinUs && us[i] <= kRcChannelMaxUs))
      throw std::invalid_argument(fmt::format("channel {}: {} us is outside {:.0f}..{:.0f} us", i + 1, us[i],
                                              kRcChannelMinUs, kRcChannelMaxUs));
  std::copy(us, us + count, part.next.us.begin());
  part.next.on = true;
}

void rc_receiver_loss(RcPart& part) { part.next.on = false; }

void rc_receiver_rearm(RcPart& part) {
  avr_t* avr = part.avr;
  const uint64_t next = service(part, avr->cycle);
  avr_cycle_timer_register(avr, next > avr->cycle ? next - avr->cycle : 1, onClock, &part);
}

RcPart::~RcPart() {
  if (!avr) return;
  avr_cycle_timer_cancel(avr, onClock, this);
  for (int i = 0; ports && i < lines; ++i) ports->releaseInput(pins[i].port, pins[i].bit);
  avr_free_irq(irq, static_cast<uint32_t>(lines));
}

}  // namespace sim

// RC receiver input (hal::Rc): port K's pin-change interrupt (PCINT2, PCINT16..23 = PK0..PK7 =
// A8..A15) queues each change of the watched pins with Timer5's count (normal mode, clk / 8:
// 0.5 us, free-running; no ESC output uses Timer5). A file of its own so that only an image
// that reads a receiver links its interrupt.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "hal/hal.hpp"

static_assert(hal::kRcPins.port == 'K' && hal::kRcTimer == 5 && hal::kRcTicksPerSecond == 2000000UL,
              "PCINT2 on port K, Timer5 at clk / 8");

namespace {
constexpr uint8_t kMask = hal::Rc::kQueueEdges - 1;
static_assert((hal::Rc::kQueueEdges & kMask) == 0, "a power-of-two queue");
volatile uint8_t g_head = 0;  // written by the interrupt
volatile uint8_t g_tail = 0;  // written by the main loop
volatile hal::Rc::Edge g_queue[hal::Rc::kQueueEdges];
volatile uint16_t g_lost = 0;
uint8_t g_watched = 0;
}  // namespace

ISR(PCINT2_vect) {
  const uint16_t ticks = TCNT5;  // interrupts are off: one consistent 16-bit read
  const uint8_t pins = PINK & g_watched;
  const uint8_t head = g_head;
  const uint8_t next = static_cast<uint8_t>((head + 1) & kMask);
  if (next == g_tail) {
    if (g_lost != 0xFFFF) g_lost = g_lost + 1;
    return;
  }
  g_queue[head].pins = pins;
  g_queue[head].ticks = ticks;
  g_head = next;
}

namespace hal {

void Rc::init(uint8_t mask) {
  PCICR &= static_cast<uint8_t>(~_BV(PCIE2));
  PCMSK2 = 0;
  g_watched = mask;
  if (mask == 0) return;
  DDRK &= static_cast<uint8_t>(~mask);  // inputs, pull-ups on
  PORTK |= mask;
  TCCR5A = 0;  // normal mode, no outputs
  TCCR5B = _BV(CS51);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    g_head = 0;
    g_tail = 0;
    g_lost = 0;
  }
  PCMSK2 = mask;
  PCIFR = _BV(PCIF2);  // a change from before is not an edge to decode
  PCICR |= _BV(PCIE2);
}

bool Rc::nextEdge(Edge& edge) {
  const uint8_t tail = g_tail;
  if (tail == g_head) return false;
  edge.pins = g_queue[tail].pins;
  edge.ticks = g_queue[tail].ticks;
  g_tail = static_cast<uint8_t>((tail + 1) & kMask);  // last: the slot is free from here
  return true;
}

uint16_t Rc::lostEdges() {
  uint16_t n;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = g_lost; }
  return n;
}

}  // namespace hal

// UART0 (the Mega2560's USB serial): 8N1, double speed (U2X0): at 115200 baud UBRR0 = 16 gives
// 117647 baud (+2.1 %), closer than the -3.5 % without U2X.
//
// Receive: RX-complete interrupt into a 64-byte ring. Nothing is dropped silently: a byte that
// does not fit, a hardware overrun (DOR0: bytes lost before this one) or a garbled byte
// (FE0 framing, UPE0 parity: the byte itself is dropped) leaves a damage mark on the next byte
// stored (a bit per ring slot), or a pending mark when nothing follows yet; read() returns
// kRxDamaged there, once per gap.
// Transmit: 128-byte ring, drained by the data-register-empty interrupt (UDRIE0 on while the
// ring holds bytes). write() waits for room only when the ring is full (a `help` is longer than
// the ring), in idle sleep, calling the wait hook and kicking the watchdog whenever the
// transmitter took a byte since the last kick: a stuck transmitter still trips the watchdog.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include <util/atomic.h>

#include "hal/hal.hpp"

namespace hal {
namespace detail {
volatile uint8_t g_uart_rx_head = 0;
volatile uint8_t g_uart_rx_tail = 0;
volatile bool g_uart_rx_gap = false;
}  // namespace detail
}  // namespace hal

namespace {
constexpr uint8_t kRxSize = 64;
constexpr uint8_t kTxSize = 128;
static_assert((kRxSize & (kRxSize - 1)) == 0, "ring buffer size must be a power of two");
static_assert((kTxSize & (kTxSize - 1)) == 0, "ring buffer size must be a power of two");

volatile uint8_t g_rx[kRxSize];
volatile uint8_t g_rx_marks[kRxSize / 8];  // bit set: bytes were lost just before this slot
volatile uint8_t& g_rx_head = hal::detail::g_uart_rx_head;  // written by the ISR only
volatile uint8_t& g_rx_tail = hal::detail::g_uart_rx_tail;  // written by read() only
volatile bool& g_rx_gap = hal::detail::g_uart_rx_gap;       // bytes lost, no byte stored since
volatile uint16_t g_rx_damage = 0;

volatile uint8_t g_tx[kTxSize];
volatile uint8_t g_tx_head = 0;  // written by write() only
volatile uint8_t g_tx_tail = 0;  // written by the ISR only

hal::Uart::WaitHook g_wait_hook = nullptr;
bool g_in_wait_hook = false;

inline uint8_t markMask(uint8_t slot) { return static_cast<uint8_t>(1u << (slot & 7)); }

void noteGap() {
  if (!g_rx_gap && g_rx_damage != 0xFFFF) g_rx_damage = g_rx_damage + 1;
  g_rx_gap = true;
}
}  // namespace

ISR(USART0_RX_vect) {
  const uint8_t status = UCSR0A;  // the flags belong to the byte in UDR0: read them first
  const uint8_t byte = UDR0;      // reading clears RXC0, also for a byte that is dropped
  if (status & _BV(DOR0)) noteGap();  // the receiver lost bytes before this one
  if (status & (_BV(FE0) | _BV(UPE0))) {
    noteGap();  // a garbled byte is not data
    return;
  }
  const uint8_t head = g_rx_head;
  const uint8_t next = static_cast<uint8_t>((head + 1) & (kRxSize - 1));
  if (next == g_rx_tail) {
    noteGap();  // ring full: this byte is lost
    return;
  }
  const uint8_t mask = markMask(head);
  if (g_rx_gap) {
    g_rx_marks[head >> 3] |= mask;
    g_rx_gap = false;
  } else {
    g_rx_marks[head >> 3] &= static_cast<uint8_t>(~mask);
  }
  g_rx[head] = byte;
  g_rx_head = next;
}

ISR(USART0_UDRE_vect) {
  const uint8_t tail = g_tx_tail;
  if (tail == g_tx_head) {
    UCSR0B &= static_cast<uint8_t>(~_BV(UDRIE0));  // ring empty: stop until write() refills it
    return;
  }
  UDR0 = g_tx[tail];
  g_tx_tail = static_cast<uint8_t>((tail + 1) & (kTxSize - 1));
}

namespace hal {

void Uart::init(uint32_t baud) {
  const uint16_t ubrr = board::uartDivisor(baud);  // its error is checked in hal/board.hpp
  // No "UCSR0B = 0" first: simavr 1.6 clears UDRE0 when TXEN0 is written 0 and only sets it
  // again after a byte went out, so the first transmit would wait forever. Read-modify-write
  // of UCSR0A for the same reason (UDRE0 is read-only on the chip).
  UCSR0A = static_cast<uint8_t>((UCSR0A & ~_BV(MPCM0)) | _BV(U2X0));
  UBRR0 = ubrr;
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);  // 8 data bits, no parity, 1 stop bit
  g_rx_head = 0;
  g_rx_tail = 0;
  g_rx_gap = false;
  g_tx_head = 0;
  g_tx_tail = 0;
  UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
  sei();
}

int16_t Uart::read() {
  const uint8_t tail = g_rx_tail;
  if (tail == g_rx_head) {
    // Bytes lost with nothing stored after them yet: report the gap now.
    bool gap = false;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
      if (g_rx_head == tail && g_rx_gap) {
        g_rx_gap = false;
        gap = true;
      }
    }
    return gap ? kRxDamaged : kNothing;
  }
  const uint8_t mask = markMask(tail);
  if (g_rx_marks[tail >> 3] & mask) {
    // The ISR writes other bits of the same byte: clear ours with interrupts off.
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { g_rx_marks[tail >> 3] &= static_cast<uint8_t>(~mask); }
    return kRxDamaged;  // the byte itself comes with the next read()
  }
  const uint8_t byte = g_rx[tail];
  g_rx_tail = static_cast<uint8_t>((tail + 1) & (kRxSize - 1));
  return byte;
}

void Uart::write(uint8_t byte) {
  const uint8_t head = g_tx_head;
  const uint8_t next = static_cast<uint8_t>((head + 1) & (kTxSize - 1));
  uint8_t seen_tail = g_tx_tail;
  while (next == g_tx_tail) {  // full: wait for the interrupt to take a byte
    if (g_wait_hook != nullptr && !g_in_wait_hook) {
      g_in_wait_hook = true;
      g_wait_hook();
      g_in_wait_hook = false;
    }
    cli();
    if (next != g_tx_tail) {
      sei();
      break;
    }
    sleep_enable();
    sei();  // sei; sleep is atomic: the byte interrupt cannot slip in between
    sleep_cpu();
    sleep_disable();
    if (g_tx_tail != seen_tail) {  // the transmitter is alive
      seen_tail = g_tx_tail;
      wdt_reset();
    }
  }
  g_tx[head] = byte;
  g_tx_head = next;
  // Not atomic (UCSR0B is memory-mapped), and need not be: the UDRE interrupt only ever clears
  // UDRIE0 after finding the ring empty, and setting it again here is what is wanted anyway.
  UCSR0B |= _BV(UDRIE0);
}

// A string into the ring in runs: as many bytes as there is room for, then the head and
// UDRIE0 once per run (~10 cycles a byte instead of a write() call's ~35); only a full ring
// goes through write(), which waits as it always does. The ISR only ever frees room, so the
// room counted from one read of the tail can only have grown by the time the head is stored.
void Uart::print(const char* text) {
  if (text == nullptr) return;
  while (*text != '\0') {
    uint8_t head = g_tx_head;
    uint8_t room = static_cast<uint8_t>((g_tx_tail - head - 1) & (kTxSize - 1));
    if (room == 0) {
      write(static_cast<uint8_t>(*text++));
      continue;
    }
    do {
      g_tx[head] = static_cast<uint8_t>(*text++);
      head = static_cast<uint8_t>((head + 1) & (kTxSize - 1));
    } while (--room != 0 && *text != '\0');
    g_tx_head = head;
    UCSR0B |= _BV(UDRIE0);
  }
}

void Uart::printP(const char* progmem_text) {
  if (progmem_text == nullptr) return;
  for (;;) {
    const uint8_t c = pgm_read_byte(progmem_text++);
    if (c == 0) return;
    write(c);
  }
}

void Uart::setWaitHook(WaitHook hook) { g_wait_hook = hook; }

uint16_t Uart::rxDamageCount() {
  uint16_t n;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = g_rx_damage; }
  return n;
}

}  // namespace hal

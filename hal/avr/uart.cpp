// UART0 (the Mega2560's USB serial): 8N1, double speed (U2X0): at 115200 baud UBRR0 = 16 gives
// 117647 baud (+2.1 %), closer than the -3.5 % without U2X. Receive: RX-complete interrupt
// into a 64-byte ring buffer (bytes arriving while it is full are dropped). Transmit: blocking
// on the data register.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>

#include "hal/hal.hpp"

namespace {
constexpr uint8_t kRxSize = 64;
static_assert((kRxSize & (kRxSize - 1)) == 0, "ring buffer size must be a power of two");
volatile uint8_t g_rx[kRxSize];
volatile uint8_t g_rx_head = 0;  // written by the ISR only
volatile uint8_t g_rx_tail = 0;  // written by read() only
}  // namespace

ISR(USART0_RX_vect) {
  const uint8_t byte = UDR0;  // read first: clears RXC0 even when the byte is dropped
  const uint8_t next = static_cast<uint8_t>((g_rx_head + 1) & (kRxSize - 1));
  if (next != g_rx_tail) {
    g_rx[g_rx_head] = byte;
    g_rx_head = next;
  }
}

namespace hal {

void Uart::init(uint32_t baud) {
  const uint16_t ubrr = static_cast<uint16_t>((F_CPU + 4 * baud) / (8 * baud) - 1);
  // No "UCSR0B = 0" first: simavr 1.6 clears UDRE0 when TXEN0 is written 0 and only sets it
  // again after a byte went out, so the first transmit would wait forever. Read-modify-write
  // of UCSR0A for the same reason (UDRE0 is read-only on the chip).
  UCSR0A = static_cast<uint8_t>((UCSR0A & ~_BV(MPCM0)) | _BV(U2X0));
  UBRR0 = ubrr;
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);  // 8 data bits, no parity, 1 stop bit
  g_rx_head = 0;
  g_rx_tail = 0;
  UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
  sei();
}

bool Uart::available() { return g_rx_head != g_rx_tail; }

int16_t Uart::read() {
  const uint8_t tail = g_rx_tail;
  if (tail == g_rx_head) return -1;
  const uint8_t byte = g_rx[tail];
  g_rx_tail = static_cast<uint8_t>((tail + 1) & (kRxSize - 1));
  return byte;
}

void Uart::write(uint8_t byte) {
  while (!(UCSR0A & _BV(UDRE0))) {
  }
  UDR0 = byte;
}

void Uart::print(const char* text) {
  if (text == nullptr) return;
  while (*text != '\0') write(static_cast<uint8_t>(*text++));
}

void Uart::printP(const char* progmem_text) {
  if (progmem_text == nullptr) return;
  for (;;) {
    const uint8_t c = pgm_read_byte(progmem_text++);
    if (c == 0) return;
    write(c);
  }
}

}  // namespace hal

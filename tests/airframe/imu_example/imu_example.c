/* imu_example: the smallest flight-board program that talks to the MPU-6050 on the TWI, for
 * trying the virtual airframe with your own code (docs/sim.md, "The virtual airframe"):
 *
 *   thrustcal sim run --elf build/host/tests/airframe/imu_example.elf --imu mpu6050 --duration 1
 *
 * It sets the bus to 400 kHz, wakes the IMU (PWR_MGMT_1 = 0), reads WHO_AM_I, then every
 * 100 ms reads the accelerometer (0x3B..0x40, one burst) and prints it raw and in milli-g
 * (+-2 g full scale: 16384 LSB/g), with the CPU cycles the read took. A polled driver with a
 * time-out on every wait, so a dead bus prints an error instead of hanging.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <stdint.h>
#include <stdlib.h>
#include <util/delay.h>

#include "avr_mcu_section.h"
AVR_MCU(F_CPU, "atmega2560");
AVR_MCU_VOLTAGES(5000, 5000, 5000);

#define IMU 0x68
#define GO ((1 << TWINT) | (1 << TWEN))

static void put(char c) {
  while (!(UCSR0A & (1 << UDRE0))) {
  }
  UDR0 = (uint8_t)c;
}
static void print(const char* s) {
  while (*s) put(*s++);
}
static void printInt(long v) {
  char b[12];
  ltoa(v, b, 10);
  print(b);
}

/* Waits for TWINT; returns the status, or 0 after a time-out (a stuck or silent bus). */
static uint8_t twi(uint8_t control) {
  TWCR = control;
  for (uint16_t n = 0; n < 60000; ++n)
    if (TWCR & (1 << TWINT)) return TWSR & 0xF8;
  return 0;
}
static void stop(void) {
  TWCR = GO | (1 << TWSTO);
  for (uint16_t n = 0; (TWCR & (1 << TWSTO)) && n < 60000; ++n) {
  }
}

/* Reads n bytes from register reg into out; returns 1 on success. */
static uint8_t readRegs(uint8_t reg, uint8_t* out, uint8_t n) {
  uint8_t ok = twi(GO | (1 << TWSTA)) == 0x08;
  if (ok) { TWDR = IMU << 1; ok = twi(GO) == 0x18; }
  if (ok) { TWDR = reg; ok = twi(GO) == 0x28; }
  if (ok) ok = twi(GO | (1 << TWSTA)) == 0x10;
  if (ok) { TWDR = (IMU << 1) | 1; ok = twi(GO) == 0x40; }
  for (uint8_t i = 0; ok && i < n; ++i) {
    const uint8_t last = i + 1 == n;
    ok = twi(GO | (last ? 0 : (1 << TWEA))) == (last ? 0x58 : 0x50);
    out[i] = TWDR;
  }
  stop();
  return ok;
}
static uint8_t writeReg(uint8_t reg, uint8_t value) {
  uint8_t ok = twi(GO | (1 << TWSTA)) == 0x08;
  if (ok) { TWDR = IMU << 1; ok = twi(GO) == 0x18; }
  if (ok) { TWDR = reg; ok = twi(GO) == 0x28; }
  if (ok) { TWDR = value; ok = twi(GO) == 0x28; }
  stop();
  return ok;
}

int main(void) {
  UCSR0A = (1 << U2X0);
  UBRR0 = 16; /* 115200 */
  UCSR0B = (1 << TXEN0);
  TWSR = 0;
  TWBR = 12;             /* SCL = 16 MHz / (16 + 2 * 12) = 400 kHz */
  TCCR1B = (1 << CS10);  /* Timer1 at clk/1 counts the cycles of a read */
  print("imu_example\r\n");
  uint8_t who = 0;
  if (!writeReg(0x6B, 0x00) || !readRegs(0x75, &who, 1)) {
    print("error: no answer from the IMU at 0x68\r\n");
  } else {
    print("WHO_AM_I 0x");
    put("0123456789ABCDEF"[who >> 4]);
    put("0123456789ABCDEF"[who & 15]);
    print("\r\n");
  }
  for (;;) {
    _delay_ms(100);
    uint8_t b[6];
    const uint16_t t0 = TCNT1;
    const uint8_t ok = readRegs(0x3B, b, 6);
    const uint16_t cycles = TCNT1 - t0;
    if (!ok) {
      print("error: accelerometer read failed\r\n");
      continue;
    }
    print("accel");
    for (uint8_t i = 0; i < 3; ++i) {
      put(' ');
      printInt((int16_t)((uint16_t)b[2 * i] << 8 | b[2 * i + 1]));
    }
    print(" raw  mg");
    for (uint8_t i = 0; i < 3; ++i) {
      put(' ');
      printInt((long)(int16_t)((uint16_t)b[2 * i] << 8 | b[2 * i + 1]) * 1000 / 16384);
    }
    print("  read ");
    printInt(cycles);
    print(" cycles\r\n");
  }
}

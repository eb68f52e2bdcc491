/* peer_quad: a small flight firmware of the project's own that behaves like a third-party peer
 * (MultiWii 2.4 on a Mega, QUADX) for the tests of `thrustcal sim swap --peer`
 * (tests/airframe/peer_test.cpp, docs/sim.md "A peer in the swap"). None of thrustcal's code:
 *
 *   motors    Timer3 and Timer4 in phase-correct PWM with ICRn as TOP (WGM 10), clk/8, ICR 2040:
 *             490 Hz, OCRnx = the pulse in us. motor[0..3] = rear-right, front-right, rear-left,
 *             front-left on D3 (OC3C), D5 (OC3A), D6 (OC4A), D2 (OC3B), as MultiWii's QUADX.
 *             Props: front-left and rear-right clockwise.
 *   receiver  one 50 Hz pulse per channel on A8..A11 (PK0..3, PCINT16..19, pull-ups on), timed
 *             with Timer5 (clk/8, 0.5 us): A8 throttle, A9 roll, A10 pitch, A11 yaw.
 *             No valid pulse on a channel for 200 ms: failsafe (disarmed, motors 1000 us).
 *   IMU       MPU-6050 at 0x68, 400 kHz, gyro +-2000 dps (16.4 LSB per dps), accelerometer +-8 g
 *             (4096 LSB per g), DLPF 42 Hz; read every 2.5 ms loop. Chip axes as the airframe's
 *             (x forward, y left, z up): roll = atan2(ay, az), pitch = atan2(-ax, az), a
 *             complementary filter with the gyro (time constant 0.5 s).
 *   arming    throttle < 1100 us and yaw > 1900 us for 1 s arms; throttle < 1100 and yaw < 1100
 *             for 1 s disarms. Armed: motors at least 1150 us (idle), at most 1950.
 *   angle     roll and pitch sticks: 1500 us level, 10 us per degree (+-25 deg); a PID on the
 *             angle error with the gyro as D, in us of pulse: Kp 1.5 per deg, Ki 1.0 per deg s,
 *             Kd 0.25 per deg/s; yaw holds its rate at 0 (P 0.6 us per deg/s). The integrators
 *             run only above 1300 us of throttle.
 *   mixer     QUADX: roll to the left motors (+) and right (-), pitch to the rear (+) and front
 *             (-), yaw to the clockwise props (+) and counter-clockwise (-).
 *   serial    UART0 115200: "peer_quad" at start, "armed" / "disarmed" / "failsafe" when that
 *             happens, "att R P" (centidegrees) every 0.5 s while armed.
 *   watchdog  120 ms; a reset starts disarmed.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "avr_mcu_section.h"
AVR_MCU(F_CPU, "atmega2560");
AVR_MCU_VOLTAGES(5000, 5000, 5000);

#define IMU 0x68
#define GO ((1 << TWINT) | (1 << TWEN))
#define LOOP_TICKS 5000u /* 2.5 ms at 0.5 us */
#define CH_THROTTLE 0
#define CH_ROLL 1
#define CH_PITCH 2
#define CH_YAW 3
#define RAD2DEG 57.29578f

static volatile uint16_t rise_[4];
static volatile uint16_t width_[4];
static volatile uint8_t fresh_; /* bit per channel: a pulse ended since the last loop */
static uint8_t pins_last_;

ISR(PCINT2_vect) {
  const uint16_t now = TCNT5;
  const uint8_t pins = PINK;
  const uint8_t changed = (uint8_t)(pins ^ pins_last_);
  pins_last_ = pins;
  for (uint8_t i = 0; i < 4; ++i) {
    const uint8_t m = (uint8_t)(1u << i);
    if (!(changed & m)) continue;
    if (pins & m) {
      rise_[i] = now;
    } else {
      const uint16_t w = (uint16_t)(now - rise_[i]) >> 1; /* us */
      if (w >= 900 && w <= 2100) {
        width_[i] = w;
        fresh_ |= m;
      }
    }
  }
}

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

static uint8_t twi(uint8_t control) {
  TWCR = control;
  for (uint16_t n = 0; n < 2000; ++n)
    if (TWCR & (1 << TWINT)) return TWSR & 0xF8;
  return 0;
}
static void stop(void) {
  TWCR = GO | (1 << TWSTO);
  for (uint16_t n = 0; (TWCR & (1 << TWSTO)) && n < 2000; ++n) {
  }
}
static uint8_t start(uint8_t reg) {
  uint8_t ok = twi(GO | (1 << TWSTA)) == 0x08;
  if (ok) { TWDR = IMU << 1; ok = twi(GO) == 0x18; }
  if (ok) { TWDR = reg; ok = twi(GO) == 0x28; }
  return ok;
}
static uint8_t readRegs(uint8_t reg, uint8_t* out, uint8_t n) {
  uint8_t ok = start(reg);
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
  uint8_t ok = start(reg);
  if (ok) { TWDR = value; ok = twi(GO) == 0x28; }
  stop();
  return ok;
}

/* motor[0..3] = rear-right D3 OC3C, front-right D5 OC3A, rear-left D6 OC4A, front-left D2 OC3B */
static void writeMotors(const uint16_t* us) {
  OCR3C = us[0];
  OCR3A = us[1];
  OCR4A = us[2];
  OCR3B = us[3];
}

static void setupMotors(void) {
  static const uint16_t stopped[4] = {1000, 1000, 1000, 1000};
  writeMotors(stopped);
  DDRE |= (1 << PE3) | (1 << PE4) | (1 << PE5);
  DDRH |= (1 << PH3);
  /* WGM 10 (phase-correct, ICR TOP): WGMn3 and WGMn1; COM clear up-counting; clk/8. */
  ICR3 = 2040;
  ICR4 = 2040;
  TCCR3A = (1 << COM3A1) | (1 << COM3B1) | (1 << COM3C1) | (1 << WGM31);
  TCCR3B = (1 << WGM33) | (1 << CS31);
  TCCR4A = (1 << COM4A1) | (1 << WGM41);
  TCCR4B = (1 << WGM43) | (1 << CS41);
}

static int16_t word(const uint8_t* b) { return (int16_t)((uint16_t)b[0] << 8 | b[1]); }
static float clampf(float v, float lo, float hi) { return v < lo ? lo : v > hi ? hi : v; }

struct Axis {
  float angle, integ;
};

/* The PID of one axis in us of pulse; sp and angle in degrees, rate in deg/s. */
static float pid(struct Axis* a, float sp, float rate, float dt, uint8_t integrate) {
  const float err = sp - a->angle;
  if (integrate) a->integ = clampf(a->integ + err * dt, -100.0f, 100.0f);
  return 1.5f * err + 1.0f * a->integ - 0.25f * rate;
}

/* The receiver's latest pulses into rc[]; returns 1 while a channel has been silent 200 ms. */
static uint8_t takeSticks(uint16_t* rc, uint16_t* age) {
  cli();
  const uint8_t got = fresh_;
  fresh_ = 0;
  for (uint8_t i = 0; i < 4; ++i)
    if (got & (1u << i)) rc[i] = width_[i];
  sei();
  uint8_t lost = 0;
  for (uint8_t i = 0; i < 4; ++i) {
    if (got & (1u << i)) age[i] = 0;
    else if (age[i] < 0xFFFF) ++age[i];
    if (age[i] > 80) lost = 1; /* 200 ms */
  }
  return lost;
}

static struct Axis roll_, pitch_;
static float gx_, gy_, gz_; /* deg/s */
static uint8_t started_;

/* Reads the IMU and updates the angles; returns 0 if the read failed. */
static uint8_t attitude(float dt) {
  uint8_t b[14];
  if (!readRegs(0x3B, b, 14)) return 0;
  const float ax = word(b), ay = word(b + 2), az = word(b + 4);
  gx_ = word(b + 8) / 16.4f, gy_ = word(b + 10) / 16.4f, gz_ = word(b + 12) / 16.4f;
  const float acc_roll = atan2f(ay, az) * RAD2DEG, acc_pitch = atan2f(-ax, az) * RAD2DEG;
  if (!started_) {
    roll_.angle = acc_roll, pitch_.angle = acc_pitch, started_ = 1;
  } else {
    const float k = 0.995f; /* 0.5 s at 2.5 ms */
    roll_.angle = k * (roll_.angle + gx_ * dt) + (1 - k) * acc_roll;
    pitch_.angle = k * (pitch_.angle + gy_ * dt) + (1 - k) * acc_pitch;
  }
  return 1;
}

/* The motors' pulses while armed: angle-mode PID and the QUADX mix. */
static void mixed(const uint16_t* rc, float dt, uint16_t* out) {
  const uint8_t integrate = rc[CH_THROTTLE] > 1300;
  const float sp_roll = clampf(((float)rc[CH_ROLL] - 1500) / 10.0f, -25, 25);
  const float sp_pitch = clampf(((float)rc[CH_PITCH] - 1500) / 10.0f, -25, 25);
  const float r = pid(&roll_, sp_roll, gx_, dt, integrate);
  const float p = pid(&pitch_, sp_pitch, gy_, dt, integrate);
  const float y = -0.6f * gz_;
  const float t = rc[CH_THROTTLE];
  /* rear-right, front-right, rear-left, front-left; FL and RR clockwise */
  const float mix[4] = {t - r + p + y, t - r - p - y, t + r + p - y, t + r - p + y};
  for (uint8_t i = 0; i < 4; ++i) out[i] = (uint16_t)clampf(mix[i], 1150, 1950);
}

static void setup(void) {
  MCUSR = 0;
  wdt_enable(WDTO_120MS);
  UCSR0A = (1 << U2X0);
  UBRR0 = 16; /* 115200 */
  UCSR0B = (1 << TXEN0);
  TWSR = 0;
  TWBR = 12; /* 400 kHz */
  TCCR5A = 0;
  TCCR5B = (1 << CS51); /* 0.5 us */
  setupMotors();
  PORTK |= 0x0F; /* pull-ups, as a receiver input */
  pins_last_ = PINK;
  PCMSK2 = 0x0F;
  PCICR = (1 << PCIE2);
  sei();
  print("peer_quad\r\n");
  writeReg(0x6B, 0x00); /* wake */
  writeReg(0x1A, 0x03); /* DLPF 42 Hz */
  writeReg(0x1B, 0x18); /* +-2000 dps */
  writeReg(0x1C, 0x10); /* +-8 g */
}

int main(void) {
  setup();
  uint16_t rc[4] = {1000, 1500, 1500, 1500};
  uint16_t age[4] = {0xFFFF, 0xFFFF, 0xFFFF, 0xFFFF}; /* loops since each channel's pulse */
  uint8_t armed = 0, failsafe = 1;
  uint16_t stick_loops = 0, print_loops = 0;
  uint16_t last = TCNT5;
  const float dt = LOOP_TICKS * 0.5e-6f;
  for (;;) {
    while ((uint16_t)(TCNT5 - last) < LOOP_TICKS) {
    }
    last += LOOP_TICKS;
    wdt_reset();
    const uint8_t lost = takeSticks(rc, age);
    if (lost && !failsafe) print("failsafe\r\n");
    if (lost) armed = 0;
    failsafe = lost;
    const uint8_t imu_ok = attitude(dt);

    const uint8_t low = !failsafe && rc[CH_THROTTLE] < 1100;
    const uint8_t want_arm = low && rc[CH_YAW] > 1900 && !armed && imu_ok;
    const uint8_t want_disarm = low && rc[CH_YAW] < 1100 && armed;
    stick_loops = (want_arm || want_disarm) ? stick_loops + 1 : 0;
    if (stick_loops >= 400) { /* 1 s */
      armed = want_arm;
      roll_.integ = pitch_.integ = 0;
      print(armed ? "armed\r\n" : "disarmed\r\n");
      stick_loops = 0;
    }

    uint16_t out[4] = {1000, 1000, 1000, 1000};
    if (armed && imu_ok) mixed(rc, dt, out);
    writeMotors(out);

    if (armed && ++print_loops >= 200) {
      print_loops = 0;
      print("att ");
      printInt(lroundf(roll_.angle * 100));
      put(' ');
      printInt(lroundf(pitch_.angle * 100));
      print("\r\n");
    }
  }
}

// An InvenSense MPU-6050 on the board's I2C bus (register map RM-MPU-6000A rev 4.2, product
// specification PS-MPU-6000A rev 3.4), as a simavr part: one struct, mpu6050_init() allocates
// its IRQs and its sample clock, mpu6050_attach() wires them to the TWI (the way simavr's
// examples/parts/i2c_eeprom.c is written).
//
// The chip model (class Mpu6050, no simavr in it) has what a flight driver uses:
//   - WHO_AM_I (0x75) 0x68; every other register 0 at power-up except PWR_MGMT_1 (0x6B) 0x40:
//     asleep, and the data registers do not change while asleep; DEVICE_RESET (0x6B bit 7).
//   - SMPLRT_DIV (0x19): data registers update at gyro output rate / (1 + div); the gyro output
//     rate is 8 kHz with DLPF_CFG 0 or 7, else 1 kHz (it is filtered at 8 kHz either way); the
//     accelerometer is sampled and filtered at 1 kHz.
//   - CONFIG (0x1A) DLPF_CFG: a low-pass with the datasheet's delay for each setting (a
//     first-order low-pass at the table's bandwidth plus a delay line making up the table's
//     delay; where the table's delay is shorter than that low-pass alone, the low-pass is
//     widened to meet the delay: docs/sim.md lists the resulting bandwidths).
//   - GYRO_CONFIG (0x1B) FS_SEL: 131 / 65.5 / 32.8 / 16.4 LSB per deg/s; ACCEL_CONFIG (0x1C)
//     AFS_SEL: 16384 / 8192 / 4096 / 2048 LSB per g; big-endian two's complement, saturated.
//   - 0x3B..0x48 accel XYZ, TEMP (raw / 340 + 36.53 C), gyro XYZ: a burst read returns one
//     sample (the user-facing copy is refreshed only while the bus is idle, as the chip does).
//   - INT_STATUS (0x3A) DATA_RDY_INT, set at each update, cleared when read.
//   - per-unit errors drawn from a seed (zero-rate offset, zero-g offset, sensitivity,
//     cross-axis) and white noise at the datasheet's densities, from a seeded generator.
//   - faults: stops answering (NACK to its address), data frozen.
// Not modelled: the FIFO, the auxiliary I2C master, the DMP, self-test, cycle mode, standby
// axes, start-up transients after wake-up, the interrupt pin. docs/sim.md has the details.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <memory>

#include "hal/board.hpp"
#include "plant/random.hpp"

struct avr_t;
struct avr_irq_t;

namespace sim {

// What the sensor feels, in its own axes (mounted along the body axes: x forward, y left, z up).
struct ImuTruth {
  std::array<double, 3> rate_dps{};                  // angular rate
  std::array<double, 3> specific_force_g{0, 0, 1};   // acceleration minus gravity: +1 g on z at rest, level
  double temp_c = 25.0;                              // die temperature
};
// The truth at simulated time t_s (non-decreasing from call to call).
using ImuTruthSource = std::function<ImuTruth(double t_s)>;

// One unit's deviations from the nominal part. Applied as
//   measured = scale * ((I + cross) * true) + offset   per sensor, then noise and the DLPF.
struct Mpu6050Errors {
  std::array<double, 3> gyro_offset_dps{};
  std::array<double, 3> accel_offset_g{};
  std::array<double, 3> gyro_scale{1, 1, 1};
  std::array<double, 3> accel_scale{1, 1, 1};
  std::array<std::array<double, 3>, 3> gyro_cross{};   // off-diagonal only
  std::array<std::array<double, 3>, 3> accel_cross{};
  // Normal, sigma = a third of the datasheet's tolerance, clamped at it: zero-rate offset
  // +-20 deg/s, zero-g offset +-50 mg (X, Y) / +-80 mg (Z), sensitivity +-3 %, cross-axis +-2 %.
  static Mpu6050Errors draw(uint64_t seed);
};

struct Mpu6050Params {
  uint8_t address = hal::kImuI2cAddress;  // 7-bit
  uint64_t seed = 1;                      // the unit (errors) and its noise
  bool unit_errors = true;                // false: a perfect part (offset 0, scale 1)
  bool noise = true;
  double gyro_noise_dps_per_rthz = 0.005;  // PS-MPU-6000A: rate noise spectral density
  double accel_noise_g_per_rthz = 400e-6;  // PS-MPU-6000A: power spectral density
};

class Mpu6050 {
 public:
  // Register addresses (RM-MPU-6000A).
  static constexpr uint8_t kSmplrtDiv = 0x19, kConfig = 0x1A, kGyroConfig = 0x1B,
                           kAccelConfig = 0x1C, kIntEnable = 0x38, kIntStatus = 0x3A,
                           kAccelXoutH = 0x3B, kTempOutH = 0x41, kGyroXoutH = 0x43,
                           kSignalPathReset = 0x68, kUserCtrl = 0x6A, kPwrMgmt1 = 0x6B,
                           kFifoRw = 0x74, kWhoAmI = 0x75;

  Mpu6050(const Mpu6050Params& params, ImuTruthSource truth);

  // --- the internal sample clock ---
  // Period of one tick: 1/8 ms (the gyro is sampled and filtered at 8 kHz, the accelerometer
  // every 8th tick).
  double tickPeriod_s() const;
  // One tick at simulated time t_s: samples the truth, filters it, and at the sample rate
  // updates the data registers (not while asleep or frozen).
  void tick(double t_s);
  // When the data registers last took a sample, and when the accelerometer value in it was
  // sampled (host side: what a reading is compared with).
  double lastLatch_s() const { return last_latch_s_; }
  double lastAccelSample_s() const { return last_accel_s_; }

  // --- I2C slave (called by the part for each bus message) ---
  bool i2cStart(uint8_t sla);            // SLA+R/W: true = ACK
  bool i2cWrite(uint8_t byte);           // the register pointer first, then data: true = ACK
  uint8_t i2cRead(bool master_acks);     // the register at the pointer; the pointer moves on
  void i2cStop();

  // --- host side (tests, logs) ---
  uint8_t reg(uint8_t addr) const { return regs_[addr & 0x7F]; }
  int16_t reg16(uint8_t addr_high) const;
  bool asleep() const;
  double sampleRate_hz() const;
  uint64_t updates() const { return updates_; }  // data register updates since power-up
  const Mpu6050Errors& errors() const { return errors_; }
  void setNack(bool on) { nack_ = on; }          // fault: stops answering its address
  void setFrozen(bool on) { frozen_ = on; }      // fault: data registers stop updating
  bool nacking() const { return nack_; }
  bool frozen() const { return frozen_; }

  // The datasheet's DLPF table (CONFIG DLPF_CFG 0..7) for the gyro and the accelerometer.
  struct DlpfRow {
    double bandwidth_hz;
    double delay_s;
  };
  static DlpfRow gyroDlpf(int cfg);
  static DlpfRow accelDlpf(int cfg);

 private:
  struct Filter {  // one axis: first-order low-pass, then a fractional delay line
    double y = 0;
    bool primed = false;
    std::array<double, 32> past{};
    int head = 0;
    double run(double x, double alpha, double delay_samples);
  };
  void powerOnReset();
  void writeRegister(uint8_t addr, uint8_t value);
  uint8_t readRegister(uint8_t addr);
  void sampleGyro(const ImuTruth& t, double period_s);
  void sampleAccel(const ImuTruth& t);
  void latch(const ImuTruth& t);
  void refreshUserRegisters();
  int dlpfCfg() const { return regs_[kConfig] & 7; }
  bool gyroFast() const;

  Mpu6050Params p_;
  ImuTruthSource truth_;
  Mpu6050Errors errors_;
  plant::Rng noise_;
  std::array<uint8_t, 128> regs_{};   // what the master reads (data: the user-facing copy)
  std::array<uint8_t, 14> sample_{};  // the internal data set, 0x3B..0x48
  std::array<Filter, 3> gyro_f_{}, accel_f_{};
  std::array<double, 3> gyro_out_dps_{}, accel_out_g_{};
  uint32_t tick_count_ = 0;
  uint32_t div_count_ = 0;
  uint64_t updates_ = 0;
  double last_latch_s_ = 0.0, last_accel_s_ = 0.0;
  bool was_asleep_ = true;
  // I2C transaction
  bool in_transaction_ = false;
  bool expect_pointer_ = false;
  uint8_t pointer_ = 0;
  bool nack_ = false, frozen_ = false;
};

// The simavr part: the chip, its IRQs and its sample clock.
struct Mpu6050Part {
  avr_t* avr = nullptr;
  avr_irq_t* irq = nullptr;  // [TWI_IRQ_INPUT] its answers, [TWI_IRQ_OUTPUT] bus messages in
  avr_irq_t* bus = nullptr;  // the TWI it is attached to
  std::unique_ptr<Mpu6050> chip;
  uint8_t selected = 0;      // the SLA byte while addressed
  uint64_t next_tick_cycle = 0;
  Mpu6050Part() = default;
  Mpu6050Part(const Mpu6050Part&) = delete;
  Mpu6050Part& operator=(const Mpu6050Part&) = delete;
  ~Mpu6050Part();  // detaches from the bus and stops its clock (the board must outlive it)
};

// Makes the chip, allocates the part's IRQs and starts its sample clock on `avr`.
void mpu6050_init(avr_t* avr, Mpu6050Part& part, const Mpu6050Params& params, ImuTruthSource truth);
// Connects the part to a TWI's IRQs (Twi::irq(), or simavr's AVR_IOCTL_TWI_GETIRQ('0') ones).
void mpu6050_attach(avr_t* avr, Mpu6050Part& part, avr_irq_t* twi_irq);
// Restarts the sample clock after a board reset (the chip has its own power and clock: the
// AVR's reset cancelled the cycle timer, not the chip's state).
void mpu6050_rearm(Mpu6050Part& part);

}  // namespace sim

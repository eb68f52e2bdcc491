// The MPU-6050 part: see sim/mpu6050.hpp.
#include "sim/mpu6050.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/board.hpp"

extern "C" {
#include <simavr/avr_twi.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_irq.h>
}

namespace sim {
namespace {

constexpr std::array<Mpu6050::DlpfRow, 8> kGyroDlpf = {{
    {256, 0.98e-3}, {188, 1.9e-3}, {98, 2.8e-3}, {42, 4.8e-3},
    {20, 8.3e-3}, {10, 13.4e-3}, {5, 18.6e-3}, {256, 0.98e-3},  // 7: reserved, as 0
}};
constexpr std::array<Mpu6050::DlpfRow, 8> kAccelDlpf = {{
    {260, 0.0}, {184, 2.0e-3}, {94, 3.0e-3}, {44, 4.9e-3},
    {21, 8.5e-3}, {10, 13.8e-3}, {5, 19.0e-3}, {260, 0.0},  // 7: reserved, as 0
}};
constexpr double kGyroLsbPerDps[4] = {131.0, 65.5, 32.8, 16.4};
constexpr double kAccelLsbPerG[4] = {16384.0, 8192.0, 4096.0, 2048.0};
constexpr double kSampleHz = 1000.0;     // accelerometer, and the gyro with DLPF_CFG 1..6
constexpr double kFastGyroHz = 8000.0;   // the gyro with DLPF_CFG 0 or 7
constexpr uint8_t kSleepBit = 0x40, kDeviceResetBit = 0x80, kTempDisBit = 0x08;
constexpr uint8_t kDataRdyBit = 0x01, kSigCondResetBit = 0x01;

// The low-pass coefficient and delay line of a DLPF row at a sample period: the low-pass gives
// min(table delay, 1 / (2 pi bandwidth)) of delay, the delay line the rest. A first-order
// y += alpha (x - y) delays by (1 - alpha) / alpha samples at low frequency.
struct DlpfDesign {
  double alpha;
  double delay_samples;
};
DlpfDesign design(const Mpu6050::DlpfRow& row, double period_s) {
  const double lp_delay_s = std::min(row.delay_s, 1.0 / (2.0 * std::numbers::pi * row.bandwidth_hz));
  const double alpha = 1.0 / (1.0 + lp_delay_s / period_s);
  return {alpha, (row.delay_s - lp_delay_s) / period_s};
}

uint64_t mix(uint64_t seed, uint64_t salt) { return seed * 0x9E3779B97F4A7C15ULL + salt; }

int16_t saturate(double counts) {
  const double r = std::round(counts);
  return static_cast<int16_t>(std::clamp(r, -32768.0, 32767.0));
}

void putBigEndian(std::array<uint8_t, 14>& out, int index, int16_t v) {
  const auto u = static_cast<uint16_t>(v);
  out[2 * index] = static_cast<uint8_t>(u >> 8);
  out[2 * index + 1] = static_cast<uint8_t>(u & 0xFF);
}

bool readOnly(uint8_t addr) { return (addr >= 0x3A && addr <= 0x60) || addr == Mpu6050::kWhoAmI; }

}  // namespace

// --- per-unit errors ---

Mpu6050Errors Mpu6050Errors::draw(uint64_t seed) {
  plant::Rng rng(mix(seed, 0x5EED0A11ULL));
  Mpu6050Errors e;
  const double accel_offset_limit_g[3] = {0.050, 0.050, 0.080};
  for (int i = 0; i < 3; ++i) e.gyro_offset_dps[i] = rng.normal(20.0 / 3.0);
  for (int i = 0; i < 3; ++i) e.accel_offset_g[i] = rng.normal(accel_offset_limit_g[i] / 3.0);
  for (int i = 0; i < 3; ++i) e.gyro_scale[i] = 1.0 + rng.normal(0.01);
  for (int i = 0; i < 3; ++i) e.accel_scale[i] = 1.0 + rng.normal(0.01);
  for (auto* m : {&e.gyro_cross, &e.accel_cross})
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) (*m)[r][c] = r == c ? 0.0 : rng.normal(0.02 / 3.0);
  return e;
}

// --- the chip ---

Mpu6050::DlpfRow Mpu6050::gyroDlpf(int cfg) { return kGyroDlpf.at(static_cast<std::size_t>(cfg & 7)); }
Mpu6050::DlpfRow Mpu6050::accelDlpf(int cfg) { return kAccelDlpf.at(static_cast<std::size_t>(cfg & 7)); }

Mpu6050::Mpu6050(const Mpu6050Params& params, ImuTruthSource truth)
    : p_(params),
      truth_(std::move(truth)),
      errors_(params.unit_errors ? Mpu6050Errors::draw(params.seed) : Mpu6050Errors{}),
      noise_(mix(params.seed, 0x0153ULL)) {
  powerOnReset();
}

void Mpu6050::powerOnReset() {
  regs_.fill(0);
  regs_[kPwrMgmt1] = kSleepBit;
  regs_[kWhoAmI] = hal::kImuWhoAmI;
  sample_.fill(0);
  gyro_f_ = {};
  accel_f_ = {};
  tick_count_ = div_count_ = 0;
  was_asleep_ = true;
}

double Mpu6050::tickPeriod_s() const { return 1.0 / kFastGyroHz; }

bool Mpu6050::gyroFast() const { return dlpfCfg() == 0 || dlpfCfg() == 7; }

double Mpu6050::sampleRate_hz() const {
  return (gyroFast() ? kFastGyroHz : kSampleHz) / (1.0 + regs_[kSmplrtDiv]);
}

bool Mpu6050::asleep() const { return (regs_[kPwrMgmt1] & kSleepBit) != 0; }

int16_t Mpu6050::reg16(uint8_t addr_high) const {
  return static_cast<int16_t>(static_cast<uint16_t>(reg(addr_high) << 8 | reg(addr_high + 1)));
}

double Mpu6050::Filter::run(double x, double alpha, double delay_samples) {
  if (!primed) {  // a wake-up starts the filter at its input, not at 0
    y = x;
    past.fill(x);
    primed = true;
  }
  y += alpha * (x - y);
  head = (head + 1) % static_cast<int>(past.size());
  past[static_cast<std::size_t>(head)] = y;
  const int k = static_cast<int>(delay_samples);
  const double frac = delay_samples - k;
  auto back = [&](int n) {
    const int size = static_cast<int>(past.size());
    return past[static_cast<std::size_t>(((head - n) % size + size) % size)];
  };
  return (1.0 - frac) * back(k) + frac * back(k + 1);
}

void Mpu6050::tick(double t_s) {
  if (asleep()) {
    was_asleep_ = true;
    return;
  }
  if (was_asleep_) {  // woken up: the filters start again from the signal
    for (auto& f : gyro_f_) f.primed = false;
    for (auto& f : accel_f_) f.primed = false;
    tick_count_ = div_count_ = 0;
    was_asleep_ = false;
  }
  const ImuTruth t = truth_(t_s);
  // The gyro is filtered at 8 kHz and put out at 8 kHz (DLPF_CFG 0, 7) or every 8th tick; the
  // accelerometer is sampled and filtered at 1 kHz.
  constexpr uint32_t kPerMs = static_cast<uint32_t>(kFastGyroHz / kSampleHz);
  const bool slow_tick = tick_count_ % kPerMs == 0;
  ++tick_count_;
  sampleGyro(t, tickPeriod_s());
  if (slow_tick) {
    sampleAccel(t);
    last_accel_s_ = t_s;
  }
  if (!gyroFast() && !slow_tick) return;
  if (++div_count_ >= 1u + regs_[kSmplrtDiv]) {
    div_count_ = 0;
    if (!frozen_) {
      latch(t);
      last_latch_s_ = t_s;
    }
  }
}

void Mpu6050::sampleGyro(const ImuTruth& t, double period_s) {
  const Mpu6050Errors& e = errors_;
  const DlpfDesign d = design(gyroDlpf(dlpfCfg()), period_s);
  const double sigma = p_.noise ? p_.gyro_noise_dps_per_rthz * std::sqrt(0.5 / period_s) : 0.0;
  for (int i = 0; i < 3; ++i) {
    double v = t.rate_dps[i];
    for (int j = 0; j < 3; ++j) v += e.gyro_cross[i][j] * t.rate_dps[j];
    v = e.gyro_scale[i] * v + e.gyro_offset_dps[i] + (sigma > 0 ? noise_.normal(sigma, 6.0) : 0.0);
    gyro_out_dps_[i] = gyro_f_[i].run(v, d.alpha, d.delay_samples);
  }
}

void Mpu6050::sampleAccel(const ImuTruth& t) {
  const Mpu6050Errors& e = errors_;
  const double period_s = 1.0 / kSampleHz;
  const DlpfDesign d = design(accelDlpf(dlpfCfg()), period_s);
  const double sigma = p_.noise ? p_.accel_noise_g_per_rthz * std::sqrt(0.5 / period_s) : 0.0;
  for (int i = 0; i < 3; ++i) {
    double v = t.specific_force_g[i];
    for (int j = 0; j < 3; ++j) v += e.accel_cross[i][j] * t.specific_force_g[j];
    v = e.accel_scale[i] * v + e.accel_offset_g[i] + (sigma > 0 ? noise_.normal(sigma, 6.0) : 0.0);
    accel_out_g_[i] = accel_f_[i].run(v, d.alpha, d.delay_samples);
  }
}

void Mpu6050::latch(const ImuTruth& t) {
  const double g_lsb = kGyroLsbPerDps[(regs_[kGyroConfig] >> 3) & 3];
  const double a_lsb = kAccelLsbPerG[(regs_[kAccelConfig] >> 3) & 3];
  for (int i = 0; i < 3; ++i) {
    putBigEndian(sample_, i, saturate(accel_out_g_[i] * a_lsb));
    putBigEndian(sample_, 4 + i, saturate(gyro_out_dps_[i] * g_lsb));
  }
  if (!(regs_[kPwrMgmt1] & kTempDisBit)) putBigEndian(sample_, 3, saturate((t.temp_c - 36.53) * 340.0));
  ++updates_;
  regs_[kIntStatus] |= kDataRdyBit;
  if (!in_transaction_) refreshUserRegisters();
}

void Mpu6050::refreshUserRegisters() {
  std::copy(sample_.begin(), sample_.end(), regs_.begin() + kAccelXoutH);
}

// --- registers over I2C ---

void Mpu6050::writeRegister(uint8_t addr, uint8_t value) {
  addr &= 0x7F;
  if (readOnly(addr)) return;
  if (addr == kPwrMgmt1 && (value & kDeviceResetBit)) {
    powerOnReset();  // every register to its reset value; the bit clears itself
    return;
  }
  regs_[addr] = value;
  const bool reset_paths = (addr == kSignalPathReset && value != 0) ||
                           (addr == kUserCtrl && (value & kSigCondResetBit));
  if (reset_paths) {
    for (auto& f : gyro_f_) f.primed = false;
    for (auto& f : accel_f_) f.primed = false;
    if (addr == kUserCtrl) {
      sample_.fill(0);
      refreshUserRegisters();
    }
    regs_[addr] = static_cast<uint8_t>(addr == kUserCtrl ? value & ~kSigCondResetBit : 0);
  }
}

uint8_t Mpu6050::readRegister(uint8_t addr) {
  addr &= 0x7F;
  const uint8_t v = regs_[addr];
  if (addr == kIntStatus) regs_[kIntStatus] = 0;  // INT_RD_CLEAR 0: cleared by reading it
  return v;
}

bool Mpu6050::i2cStart(uint8_t sla) {
  in_transaction_ = false;
  if ((sla >> 1) != p_.address || nack_) return false;
  in_transaction_ = true;
  expect_pointer_ = (sla & 1) == 0;
  return true;
}

bool Mpu6050::i2cWrite(uint8_t byte) {
  if (!in_transaction_) return false;
  if (expect_pointer_) {
    pointer_ = byte & 0x7F;
    expect_pointer_ = false;
  } else {
    writeRegister(pointer_, byte);
    pointer_ = static_cast<uint8_t>((pointer_ + 1) & 0x7F);
  }
  return true;
}

uint8_t Mpu6050::i2cRead(bool) {
  const uint8_t v = readRegister(pointer_);
  if (pointer_ != kFifoRw) pointer_ = static_cast<uint8_t>((pointer_ + 1) & 0x7F);
  return v;
}

void Mpu6050::i2cStop() {
  in_transaction_ = false;
  refreshUserRegisters();  // the interface is idle: the user-facing copy catches up
}

// --- the simavr part ---

namespace {

const char* kPartIrqNames[2] = {"8>mpu6050.out", "32<mpu6050.in"};

void onBusMessage(avr_irq_t*, uint32_t value, void* param) {
  auto* p = static_cast<Mpu6050Part*>(param);
  avr_twi_msg_irq_t v;
  v.u.v = value;
  const uint8_t msg = v.u.twi.msg;
  if (msg & TWI_COND_STOP) {
    if (p->selected) p->chip->i2cStop();
    p->selected = 0;
  }
  if (msg & TWI_COND_START) {
    p->selected = 0;
    if (p->chip->i2cStart(v.u.twi.addr)) {
      p->selected = v.u.twi.addr;
      avr_raise_irq(p->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_ACK, p->selected, 1));
    }
  }
  if (!p->selected) return;
  if ((msg & TWI_COND_WRITE) && p->chip->i2cWrite(v.u.twi.data))
    avr_raise_irq(p->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_ACK, p->selected, 1));
  if (msg & TWI_COND_READ) {
    const uint8_t byte = p->chip->i2cRead((msg & TWI_COND_ACK) != 0);
    avr_raise_irq(p->irq + TWI_IRQ_INPUT, avr_twi_irq_msg(TWI_COND_READ, p->selected, byte));
  }
}

uint64_t periodCycles(const Mpu6050& chip) {
  return static_cast<uint64_t>(std::llround(chip.tickPeriod_s() * kCpuHz));
}

uint64_t onSampleClock(avr_t*, uint64_t when, void* param) {
  auto* p = static_cast<Mpu6050Part*>(param);
  p->chip->tick(cyclesToSeconds(when));
  p->next_tick_cycle = when + periodCycles(*p->chip);
  return p->next_tick_cycle;
}

}  // namespace

void mpu6050_init(avr_t* avr, Mpu6050Part& part, const Mpu6050Params& params, ImuTruthSource truth) {
  part.avr = avr;
  part.chip = std::make_unique<Mpu6050>(params, std::move(truth));
  part.irq = avr_alloc_irq(&avr->irq_pool, 0, 2, kPartIrqNames);
  avr_irq_register_notify(part.irq + TWI_IRQ_OUTPUT, onBusMessage, &part);
  part.next_tick_cycle = avr->cycle + periodCycles(*part.chip);
  mpu6050_rearm(part);
}

void mpu6050_attach(avr_t*, Mpu6050Part& part, avr_irq_t* twi_irq) {
  part.bus = twi_irq;
  avr_connect_irq(part.irq + TWI_IRQ_INPUT, twi_irq + TWI_IRQ_INPUT);
  avr_connect_irq(twi_irq + TWI_IRQ_OUTPUT, part.irq + TWI_IRQ_OUTPUT);
}

void mpu6050_rearm(Mpu6050Part& part) {
  avr_t* avr = part.avr;
  avr_cycle_timer_cancel(avr, onSampleClock, &part);
  const uint64_t period = periodCycles(*part.chip);
  while (part.next_tick_cycle <= avr->cycle) part.next_tick_cycle += period;  // the chip's own phase
  avr_cycle_timer_register(avr, part.next_tick_cycle - avr->cycle, onSampleClock, &part);
}

Mpu6050Part::~Mpu6050Part() {
  if (!avr) return;
  avr_cycle_timer_cancel(avr, onSampleClock, this);
  if (bus) {
    avr_unconnect_irq(irq + TWI_IRQ_INPUT, bus + TWI_IRQ_INPUT);
    avr_unconnect_irq(bus + TWI_IRQ_OUTPUT, irq + TWI_IRQ_OUTPUT);
  }
  avr_irq_unregister_notify(irq + TWI_IRQ_OUTPUT, onBusMessage, this);
  avr_free_irq(irq, 2);
}

}  // namespace sim

// The MPU-6050 driver (mpu6050.hpp). onPhase runs in the ESC frame's phase interrupt, the rest
// in the main loop. What they share is volatile and each field has one writer: the main loop
// writes the prepared transfer (op_*) and then transfer_ = kQueued; the interrupt reads op_*
// only after seeing kQueued, and writes phase_, started_phase_, skipped_ and transfer_ =
// kInFlight / kRefused; the main loop takes a transfer back (finish) only once it has ended or
// its frame is over.
#include "mpu6050.hpp"

#include "thrustcal/flash_text.hpp"

namespace fly {

namespace {

using Result = hal::Twi::Result;

// What start-up writes, in this order (kConfigure), then reads back from SMPLRT_DIV (kVerify).
struct Setting {
  uint8_t reg;
  uint8_t value;
};
const Setting kSettings[] TC_FLASH = {
    {mpu::kPwrMgmt1, mpu::kClockGyroZ}, {mpu::kSmplrtDiv, mpu::kDivider1kHz},
    {mpu::kConfig, mpu::kDlpf98Hz},     {mpu::kGyroConfig, mpu::kGyro2000Dps},
    {mpu::kAccelConfig, mpu::kAccel8G}, {mpu::kIntEnable, mpu::kDataRdy},
};
constexpr uint8_t kSettingCount = sizeof kSettings / sizeof kSettings[0];
constexpr uint8_t kVerifyBytes = 4;  // SMPLRT_DIV, CONFIG, GYRO_CONFIG, ACCEL_CONFIG
static_assert(mpu::kConfig == mpu::kSmplrtDiv + 1 && mpu::kGyroConfig == mpu::kSmplrtDiv + 2 &&
                  mpu::kAccelConfig == mpu::kSmplrtDiv + 3,
              "the four settings read back in one burst");

bool settingsReadBack(const uint8_t (&got)[kVerifyBytes]) {
  return got[0] == mpu::kDivider1kHz && got[1] == mpu::kDlpf98Hz && got[2] == mpu::kGyro2000Dps &&
         got[3] == mpu::kAccel8G;
}

int16_t bigEndian(const uint8_t* p) {
  return static_cast<int16_t>((static_cast<uint16_t>(p[0]) << 8) | p[1]);
}

bool busTrouble(Result r) { return r == Result::kAborted || r == Result::kLost || r == Result::kBusError; }

}  // namespace

ImuSample decodeSample(const uint8_t (&bytes)[mpu::kSampleBytes]) {
  ImuSample s;
  s.fresh = (bytes[0] & mpu::kDataRdy) != 0;
  for (uint8_t i = 0; i < 3; ++i) {
    s.accel[i] = bigEndian(&bytes[1 + 2 * i]);
    s.gyro[i] = bigEndian(&bytes[9 + 2 * i]);
  }
  s.temp = bigEndian(&bytes[7]);
  return s;
}

void Mpu6050::begin() {
  state_ = ImuState::kWhoAmI;
  step_ = 0;
  bad_reads_ = 0;
  stale_reads_ = 0;
  prepareNext();
}

void Mpu6050::onPhase() {
  phase_ = static_cast<uint8_t>(phase_ + 1);
  const Transfer t = transfer_;
  if (t == Transfer::kQueued) {
    const bool started = op_length_ != 0 ? hal::Twi::startRead(hal::kImuI2cAddress, op_reg_, op_length_)
                                         : hal::Twi::startWrite(hal::kImuI2cAddress, op_reg_, op_value_);
    started_phase_ = phase_;
    transfer_ = started ? Transfer::kInFlight : Transfer::kRefused;
  } else if (t != Transfer::kIdle && skipped_ != 0xFFFF) {
    skipped_ = static_cast<uint16_t>(skipped_ + 1);  // the last frame's result is not taken yet
  }
}

bool Mpu6050::poll(ImuFrame& out) {
  const uint8_t phase = phase_;
  if (phase == handled_phase_) return false;
  out = ImuFrame();
  const Transfer t = transfer_;
  if (t == Transfer::kInFlight) {
    Result r = hal::Twi::result();
    if (r == Result::kBusy) {
      if (phase == started_phase_) return false;  // its frame is not over yet
      hal::Twi::abort();                          // a whole frame: timed out
      r = Result::kAborted;
    }
    transfer_ = Transfer::kIdle;
    finish(r, out);
  } else if (t == Transfer::kRefused) {
    transfer_ = Transfer::kIdle;
    finish(Result::kBusError, out);  // the TWI could not start: a STOP never got out
  }
  out.frames = static_cast<uint8_t>(phase - handled_phase_);
  handled_phase_ = phase;
  if (state_ == ImuState::kResetWait || state_ == ImuState::kFaulted) {
    wait_frames_ = wait_frames_ > out.frames ? static_cast<uint16_t>(wait_frames_ - out.frames) : 0;
    if (wait_frames_ == 0 && state_ == ImuState::kResetWait) {
      state_ = ImuState::kConfigure;
      step_ = 0;
    } else if (wait_frames_ == 0) {
      hal::Twi::recoverBus();  // whatever went wrong, start from a free bus
      begin();
      return true;
    }
  }
  prepareNext();
  return true;
}

void Mpu6050::finish(hal::Twi::Result result, ImuFrame& out) {
  if (result != Result::kDone) last_status_ = result == Result::kAborted ? kTimedOut : hal::Twi::lastStatus();
  const uint16_t faults_before = faults_;
  if (state_ == ImuState::kRunning) {
    takeSample(result, out);
  } else {
    advanceStartUp(result);
  }
  out.fault_now = faults_ != faults_before;
}

void Mpu6050::advanceStartUp(Result result) {
  if (result != Result::kDone) {
    recoverIfStuck(result);
    faulted(result == Result::kNack ? ImuFault::kNoAnswer : ImuFault::kBusStuck);
    return;
  }
  switch (state_) {
    case ImuState::kWhoAmI:
      hal::Twi::readData(&who_am_i_, 1);
      if (who_am_i_ != hal::kImuWhoAmI) {
        faulted(ImuFault::kWrongId);
        return;
      }
      state_ = ImuState::kReset;
      break;
    case ImuState::kReset:
      state_ = ImuState::kResetWait;
      wait_frames_ = mpu::kResetFrames;
      break;
    case ImuState::kConfigure:
      step_ = static_cast<uint8_t>(step_ + 1);
      if (step_ >= kSettingCount) state_ = ImuState::kVerify;
      break;
    case ImuState::kVerify: {
      uint8_t got[kVerifyBytes] = {};
      hal::Twi::readData(got, kVerifyBytes);
      if (!settingsReadBack(got)) {
        faulted(ImuFault::kBadConfig);
        return;
      }
      state_ = ImuState::kRunning;
      fault_ = ImuFault::kNone;
      bad_reads_ = 0;
      stale_reads_ = 0;
      break;
    }
    default:
      break;
  }
}

// A read that ended badly counts; kImuMaxBadReads in a row is a fault. A stale sample (no
// DATA_RDY) is not used; kImuMaxStaleReads in a row is frozen data.
void Mpu6050::takeSample(Result result, ImuFrame& out) {
  if (result != Result::kDone) {
    recoverIfStuck(result);
    if (bad_reads_ != 0xFF) ++bad_reads_;
    if (imuReadsFailed(bad_reads_))
      faulted(result == Result::kNack ? ImuFault::kNoAnswer : ImuFault::kBusStuck);
    return;
  }
  bad_reads_ = 0;
  uint8_t bytes[mpu::kSampleBytes] = {};
  hal::Twi::readData(bytes, mpu::kSampleBytes);
  out.sample = decodeSample(bytes);
  ++reads_ok_;
  if (out.sample.fresh) {
    stale_reads_ = 0;
    out.has_sample = true;
    return;
  }
  if (stale_reads_ != 0xFF) ++stale_reads_;
  if (imuFrozen(stale_reads_)) faulted(ImuFault::kFrozen);
}

void Mpu6050::faulted(ImuFault why) {
  fault_ = why;
  state_ = ImuState::kFaulted;
  wait_frames_ = mpu::kRetryFrames;
  if (faults_ != 0xFFFF) ++faults_;
}

void Mpu6050::recoverIfStuck(Result result) {
  if (!busTrouble(result)) return;
  hal::Twi::recoverBus();
  if (recoveries_ != 0xFFFF) ++recoveries_;
}

void Mpu6050::queue(const Op& op) {
  op_reg_ = op.reg;
  op_value_ = op.value;
  op_length_ = op.length;
  transfer_ = Transfer::kQueued;  // last: the interrupt reads op_* only after this
}

void Mpu6050::prepareNext() {
  switch (state_) {
    case ImuState::kWhoAmI:
      queue({mpu::kWhoAmI, 0, 1});
      break;
    case ImuState::kReset:
      queue({mpu::kPwrMgmt1, mpu::kDeviceReset, 0});
      break;
    case ImuState::kConfigure: {
      Setting s;
      tc::flashCopy(&s, &kSettings[step_], sizeof s);
      queue({s.reg, s.value, 0});
      break;
    }
    case ImuState::kVerify:
      queue({mpu::kSmplrtDiv, 0, kVerifyBytes});
      break;
    case ImuState::kRunning:
      queue({mpu::kIntStatus, 0, mpu::kSampleBytes});
      break;
    default:  // kResetWait, kFaulted: no transfer this frame
      transfer_ = Transfer::kIdle;
      break;
  }
}

}  // namespace fly

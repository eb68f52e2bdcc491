// The MPU-6050 on the TWI bus (RM-MPU-6000A rev 4.2, PS-MPU-6000A rev 3.4): its registers, the
// configuration fly gives it and a driver paced by fly's frames.
//
// One transfer per frame: the driver prepares it in the main loop, the ESC frame's phase hook
// (an interrupt, onPhase) starts it, the TWI interrupt runs it, and the main loop's poll() takes
// the result once it has ended, or aborts it when the next frame's phase came first (the
// time-out: a read takes about a fifth of a frame). Start-up, one step per frame: WHO_AM_I must
// read 0x68; DEVICE_RESET, 100 ms; wake on the gyro's clock; 1 kHz samples with the 98 Hz low-pass
// (2.8 ms delay, well inside the 200 Hz a 400 Hz loop sees); +-2000 deg/s and +-8 g (a crash
// does not saturate them); DATA_RDY flagged; the four settings read back. Then every frame a
// burst of INT_STATUS and the 14 data bytes (0x3A..0x48: one consistent sample): DATA_RDY says
// whether a new sample came since the last read (frozen data, whatever the data look like).
//
// Health: a read that ends badly (NACK, time-out, arbitration lost, bus error) counts, and after
// a time-out or a lost bus the bus is recovered (hal::Twi::recoverBus); kImuMaxBadReads bad or
// kImuMaxStaleReads stale reads in a row are a fault, as is a wrong WHO_AM_I or settings that
// did not stick. A faulted driver starts again after a second (the gyro bias it had stays
// valid: same chip). fly disarms on any fault.
// A stage of fly's loop: it hands out ImuSample (flight_types.hpp) and depends on no other stage.
#pragma once
#include <stdint.h>

#include "flight_types.hpp"
#include "hal/hal.hpp"

namespace fly {

namespace mpu {
constexpr uint8_t kSmplrtDiv = 0x19;
constexpr uint8_t kConfig = 0x1A;
constexpr uint8_t kGyroConfig = 0x1B;
constexpr uint8_t kAccelConfig = 0x1C;
constexpr uint8_t kIntEnable = 0x38;
constexpr uint8_t kIntStatus = 0x3A;
constexpr uint8_t kPwrMgmt1 = 0x6B;
constexpr uint8_t kWhoAmI = 0x75;

constexpr uint8_t kDeviceReset = 0x80;  // PWR_MGMT_1
constexpr uint8_t kClockGyroZ = 0x03;   // PWR_MGMT_1: awake, PLL on the Z gyro
constexpr uint8_t kDivider1kHz = 0;     // SMPLRT_DIV: 1 kHz / (1 + 0)
constexpr uint8_t kDlpf98Hz = 2;        // CONFIG DLPF_CFG
constexpr uint8_t kGyro2000Dps = 0x18;  // GYRO_CONFIG FS_SEL 3
constexpr uint8_t kAccel8G = 0x10;      // ACCEL_CONFIG AFS_SEL 2
constexpr uint8_t kDataRdy = 0x01;      // INT_ENABLE / INT_STATUS

constexpr uint8_t kSampleBytes = 15;                  // INT_STATUS, accel XYZ, TEMP, gyro XYZ
constexpr uint16_t kResetFrames = framesIn(100);      // after DEVICE_RESET
constexpr uint16_t kRetryFrames = framesIn(1000);     // after a fault
static_assert(kGyro2000Dps == 0x18 && kAccel8G == 0x10, "the full scales flight_types.hpp's units are");
static_assert(kDivider1kHz == 0 && kImuSampleHz == 1000, "1 kHz samples with the low-pass on");
}  // namespace mpu

// The IMU failed: this many reads in a row ended badly (no answer, a time-out, the bus lost) or
// brought no new sample (DATA_RDY clear: frozen data), 20 ms of frames.
constexpr uint8_t kImuMaxBadReads = static_cast<uint8_t>(framesIn(20));
constexpr uint8_t kImuMaxStaleReads = static_cast<uint8_t>(framesIn(20));
inline bool imuReadsFailed(uint8_t bad_in_a_row) { return bad_in_a_row >= kImuMaxBadReads; }
inline bool imuFrozen(uint8_t stale_in_a_row) { return stale_in_a_row >= kImuMaxStaleReads; }

// The 15 bytes of a burst from INT_STATUS (big-endian two's complement).
ImuSample decodeSample(const uint8_t (&bytes)[mpu::kSampleBytes]);

enum class ImuState : uint8_t { kWhoAmI, kReset, kResetWait, kConfigure, kVerify, kRunning, kFaulted };
enum class ImuFault : uint8_t {
  kNone,
  kNoAnswer,   // NACK at its address: not there, not powered, wrong address
  kWrongId,    // WHO_AM_I is not 0x68: another chip
  kBusStuck,   // transfers never end or lose the bus, even after recovery
  kBadConfig,  // its settings did not read back
  kFrozen,     // no new sample (DATA_RDY) for kImuMaxStaleReads reads
};

// What one frame brought.
struct ImuFrame {
  uint8_t frames = 0;       // frames since the last one handled (1 unless the loop was late)
  bool has_sample = false;  // a read ended well this frame: `sample` is it
  bool fault_now = false;   // the driver faulted in this frame
  ImuSample sample;
};

class Mpu6050 {
 public:
  // (Re)starts the start-up sequence at the next frame.
  void begin();
  // From the ESC frame's phase hook (interrupt): counts the frame and starts the prepared
  // transfer. Short.
  void onPhase();
  // Main loop: true once per frame, when that frame's transfer has ended (or timed out, or none
  // was due); `out` says what it brought. Prepares the next frame's transfer.
  bool poll(ImuFrame& out);
  // Whether poll() has a frame to hand out now (with interrupts off: the sleep's last check,
  // after every interrupt: inline, ~20 times a frame).
  __attribute__((always_inline)) bool frameDue() const {
    const uint8_t phase = phase_;
    if (phase == handled_phase_) return false;
    return transfer_ != Transfer::kInFlight || phase != started_phase_ ||
           hal::Twi::result() != hal::Twi::Result::kBusy;
  }

  ImuState state() const { return state_; }
  ImuFault fault() const { return fault_; }
  bool running() const { return state_ == ImuState::kRunning; }
  static constexpr uint8_t kTimedOut = 0xF8;           // lastStatus() of a transfer that never ended
  uint8_t whoAmI() const { return who_am_i_; }         // what WHO_AM_I read last
  uint8_t lastStatus() const { return last_status_; }  // TWSR code of the last bad transfer
  uint8_t badReads() const { return bad_reads_; }      // in a row
  uint8_t staleReads() const { return stale_reads_; }  // in a row
  uint32_t readsOk() const { return reads_ok_; }
  uint16_t faults() const { return faults_; }          // since start-up (saturates)
  uint16_t recoveries() const { return recoveries_; }  // bus recoveries (saturates)
  uint16_t skippedFrames() const { return skipped_; }  // phases with no transfer started (loop late)

 private:
  enum class Transfer : uint8_t { kIdle, kQueued, kInFlight, kRefused };
  struct Op {
    uint8_t reg;
    uint8_t value;   // a write's value
    uint8_t length;  // 0: a write
  };

  void queue(const Op& op);
  void prepareNext();
  void finish(hal::Twi::Result result, ImuFrame& out);
  void advanceStartUp(hal::Twi::Result result);
  void takeSample(hal::Twi::Result result, ImuFrame& out);
  void faulted(ImuFault why);
  void recoverIfStuck(hal::Twi::Result result);

  // Shared with onPhase (interrupt): written by one side each (see the .cpp).
  volatile uint8_t phase_ = 0;
  volatile uint8_t started_phase_ = 0;
  volatile Transfer transfer_ = Transfer::kIdle;
  volatile uint8_t op_reg_ = 0;
  volatile uint8_t op_value_ = 0;
  volatile uint8_t op_length_ = 0;
  volatile uint16_t skipped_ = 0;

  uint8_t handled_phase_ = 0;
  ImuState state_ = ImuState::kWhoAmI;
  ImuFault fault_ = ImuFault::kNone;
  uint8_t step_ = 0;          // kConfigure: the setting being written
  uint16_t wait_frames_ = 0;  // kResetWait, kFaulted
  uint8_t who_am_i_ = 0;
  uint8_t last_status_ = 0;
  uint8_t bad_reads_ = 0;
  uint8_t stale_reads_ = 0;
  uint32_t reads_ok_ = 0;
  uint16_t faults_ = 0;
  uint16_t recoveries_ = 0;
};

}  // namespace fly

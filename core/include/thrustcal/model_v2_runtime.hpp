// Model v2 as read_run flies it: one ESC frame for the motors of one aircraft, on one bus.
//
// What a frame computes, per motor i flying v2:
//   drive_i = curve_i(F_i)                       (model_v2.hpp, fixed point, as forceToPwmV2)
//   PWM_i   = start_i + drive_i / V_cmd
//   V_cmd   = V_filtered + sag_seen - sum_j sag_j(F_j)
// V_filtered is the bus reading through BusVoltageFilter (first order, ~150 ms). It lags the
// motors: after a command step it still shows the sag of the forces before the step. The
// sag each motor caused on its bench (sag_j, from the record's knots) predicts where the bus
// goes: sag_seen is the total bench sag of the commands filtered exactly like the reading,
// i.e. the part of the sag the filtered reading already shows. All motors hang on the same
// pack, so the bus drop at the commands is the SUM over the motors (one prediction per frame,
// shared by all of them); in steady state sag_seen equals the sum and V_cmd = V_filtered: the
// plain model.
//
// Precision: the plain path (no predicted change) is bit for bit forceToPwmV2(model, F, bus)
// (tests/core_v2/model_v2_frame_test.cpp compares every force). The predicted voltage enters
// as a corrected reciprocal, 1/V_cmd = (1/V) (1 - e + e^2) with e = (V_cmd - V) / V clamped to
// +-25 % (error e^3: < 0.01 % for a 5 % step), rounded to the same 2^26 / mV scale the plain
// path uses.
//
// Cost on the ATmega2560 (avr-g++ -Os, simavr; `thrustcal bench compute` measures it): per
// motor three 16 x 16 multiplications (knot position, drive interpolation, duty) and two 8 x 8
// (sag interpolation); per frame three more for the prediction. No division, no loop over the
// knots, no 32-bit shift by a non-multiple of 8.
//
// Layout (ModelV2Run): built once at load from a finalized ModelV2. The knots are one table of
// (drive, sag) entries with the origin in front and the last knot repeated behind, so the two
// knots around any force are entries [k] and [k + 1] with no edge test (force == the curve's
// end lands on k == knots); one pointer reaches both entries' four fields.
#pragma once
#include <stdint.h>

#include "thrustcal/model_v2.hpp"

namespace tc {

// Largest number of motors one frame flies (read_run's four slots).
constexpr uint8_t kV2FrameMaxMotors = 4;

struct ModelV2Run {
  struct Knot {  // 4 bytes: the knot's offset is its index times 4
    uint16_t drive_512usmv;
    uint8_t sag_10mv;
    uint8_t unused;
  };
  // Per-frame fields first: all within the AVR's ldd reach (63 bytes) of the model pointer.
  uint16_t max_force_dg = 0;    // 0 = no model
  uint16_t split_dg = 0;        // where the coarse knots begin (ModelV2::split_dg)
  uint16_t inv_step_q22 = 0;
  uint16_t inv_coarse_q22 = 0;
  uint8_t fine_knots = 0;
  uint8_t knots = 0;
  uint8_t q16_inverse = 0;      // inv_step_q22 holds 2^16 / step (ModelV2::q16_inverse)
  uint32_t start_round_q17_us = 0;  // start threshold + 1/2 us, 2^-17 us
  uint16_t rest_recip_q27 = 0;  // the voltage flown while the bus reading is not valid
  // Status only (headroom): the knots' forces and the resting reading.
  uint16_t step_dg = 0;
  uint16_t coarse_step_dg = 0;
  uint16_t rest_mv = 0;
  Knot knot[kV2MaxKnots + 2] = {};  // [0] origin, [k + 1] stored knot k, [knots + 1] = [knots]

  // From a finalized model; false (and cleared) when `model` is absent.
  bool load(const ModelV2& model);
  void clear() { *this = ModelV2Run(); }
  bool isPresent() const { return max_force_dg != 0; }
  uint16_t startQ4Us() const { return static_cast<uint16_t>((start_round_q17_us - 0x10000ul) >> 13); }
  uint16_t knotForceDg(uint8_t k) const {  // stored knot k (0-based), as ModelV2::knotForceDg
    return k < fine_knots ? static_cast<uint16_t>((k + 1) * step_dg)
                          : static_cast<uint16_t>(split_dg + (k + 1 - fine_knots) * coarse_step_dg);
  }
};

// The total bench sag of the commanded forces, filtered like the bus reading (same shift,
// same exact first-order step as BusVoltageFilter), in 1/16 of kV2SagUnitMv; last_q4 is the
// total of the last frame's commands.
struct BusSagFilter {
  uint16_t seen_q4 = 0;
  uint8_t rem = 0;
  uint16_t last_q4 = 0;
};

// One motor of a frame: the command in, the pulse and its flags out. Field order is fixed: the
// AVR pass walks it.
struct V2Lane {
  const ModelV2Run* model = nullptr;  // set with setModel()
  uint16_t force_dg = 0;
  uint8_t start_q17[3] = {};  // bytes 1..3 of the model's start_round_q17_us (byte 0 is 0)
  uint8_t flags = kNotCalibrated;  // tc::ForcePwmFlag bits of pwm_us
  uint16_t pwm_us = kStopPwmUs;

  // Flies `m` (a loaded model): keeps its start threshold next to the command.
  void setModel(const ModelV2Run* m) {
    model = m;
    start_q17[0] = static_cast<uint8_t>(m->start_round_q17_us >> 8);
    start_q17[1] = static_cast<uint8_t>(m->start_round_q17_us >> 16);
    start_q17[2] = static_cast<uint8_t>(m->start_round_q17_us >> 24);
  }
  uint32_t startRoundQ17() const {
    return (static_cast<uint32_t>(start_q17[2]) << 24) | (static_cast<uint32_t>(start_q17[1]) << 16) |
           (static_cast<uint32_t>(start_q17[0]) << 8);
  }
  ForcePwmResult result() const { return ForcePwmResult{pwm_us, flags}; }
};

// Everything one ESC frame of the motors flying v2 reads and writes, in one place (the AVR
// frame reaches it all from one pointer).
struct V2Frame {
  BusVoltageFilter bus;  // the battery reading through the first-order filter
  BusSagFilter sag;      // the commands' bench sag, filtered alike
  uint16_t pwm_min_us = kThrottleMinUs;
  uint16_t pwm_max_us = kThrottleMaxUs;
  uint8_t count = 0;     // lanes in use (<= kV2FrameMaxMotors)
  V2Lane lane[kV2FrameMaxMotors];

  // One frame: `bus` takes this frame's reading `sample_mv` (exactly BusVoltageFilter::update),
  // then per lane, as forceToPwmV2 at the filtered voltage: force 0 -> pwm_min, kStopped;
  // force above the curve -> its end, kSaturated; PWM above/below the limits -> the limit,
  // kSaturated / kClamped; bus not valid -> each model's resting voltage, kVoltageInvalid, no
  // prediction. Every lane in use must hold a loaded model. `extra_flags` are or-ed into every
  // lane's flags (read_run: kVoltageInvalid while it flies on the last good reading). The sag
  // prediction uses the last frame's commands (one frame late: 20 ms at 50 Hz, well inside
  // the motors' time constant), which keeps the frame one pass over the motors.
  void fly(uint16_t sample_mv, uint8_t extra_flags = 0);
  // The same in portable C++ (what the host runs; on the AVR fly() is assembly): the bench
  // probe runs both on the same frames and counts differences.
  void flyPortable(uint16_t sample_mv, uint8_t extra_flags = 0);
};

// Headroom for the status command, as headroomDg(ModelV2) (one division).
uint16_t headroomDg(const ModelV2Run& model, uint16_t vbus_mv,
                    const ForcePwmLimits& limits = ForcePwmLimits());

}  // namespace tc

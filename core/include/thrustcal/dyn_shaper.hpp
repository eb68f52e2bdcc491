// Equal dynamics in flight (issue 26 item 3): each motor's force command shaped with its own
// measured response (thrustcal/dynamics.hpp) so that every motor's force follows one common
// reference response, whatever its own time constants.
//
// The motor's force follows its command u as a first-order lag, per frame of dt:
//     y[k+1] = y[k] + a_m (u[k] - y[k]),   a_m = 1 - exp(-dt / tau_motor)
// and the reference follows the requested force F the same way with the reference's constant:
//     r[k+1] = r[k] + a_r (F[k] - r[k]),   a_r = 1 - exp(-dt / tau_ref)
// With y == r, the command that makes the motor land on the reference next frame is
//     u[k] = r[k] + (a_r / a_m) (F[k] - r[k])
// (in continuous time u = r + tau_motor dr/dt, C(s) = (tau_motor s + 1) / (tau_ref s + 1)).
// tau_motor and tau_ref each follow their law at the operating point (the reference's force),
// spin-up or spin-down by the sign of F - r.
//
// Pulse limits: F is first limited to what the model makes (0..max); when u falls outside
// 1 dg..max (a reference faster than the motor asks for more than the motor can be given), u
// is held at the limit and the reference advances as the motor does under that command, so the
// reference stays what the motor can achieve and nothing winds up. F == 0 is a stop: the
// output is 0 at once (no shaping on the way to the stop pulse) and the reference decays as
// the motor spins down.
//
// Split by cost: configure() (float, expf; when shaping is switched on, or the frame rate or
// the records change) tabulates a_m, a_r / a_m and a_r at kShaperBins + 1 forces per direction,
// evenly spaced over the motors' range; step() (every frame, integer only: 32 x 16 and 16 x 8
// multiplications, no division) interpolates them linearly at the reference's force. Taking the
// value of the bin the reference is in instead moved a motor's gain by up to the law's change
// over half a bin (51-102 g bins: about 1 % of tau), so a motor hovering a few grams either side
// of a bin edge followed the reference up to 1 % faster or slower. A motor without dynamics (a
// thesis record, a v2 record before `dyn`) is not shaped: step() passes its force through
// unchanged.
#pragma once
#include <stdint.h>

#include "thrustcal/dynamics.hpp"

namespace tc {

constexpr uint8_t kShaperBins = 16;      // force intervals per direction (kShaperBins + 1 points)
constexpr uint8_t kShaperPoints = kShaperBins + 2;  // the points, and the last repeated (the
                                                    // open-ended interval interpolates to it)
constexpr uint8_t kShaperUp = 0;         // table index: F above the reference
constexpr uint8_t kShaperDown = 1;       // ... below it
constexpr uint16_t kShaperGainMaxQ14 = 0xFFFF;  // a_r / a_m at most ~4: a reference up to 4x faster

// The common reference. Fixed: tau_up / tau_down in 0.1 ms for every force (both nonzero).
// Slowest (both 0): at every force the slowest of the shaped motors' own laws there, so no
// motor is asked for more than it can do.
struct ShaperReference {
  uint16_t tau_up_01ms = 0;
  uint16_t tau_down_01ms = 0;

  bool isSlowest() const { return tau_up_01ms == 0 && tau_down_01ms == 0; }
  // Fixed reference within the records' range (kDynTauMin01ms..kDynTauMax01ms), or slowest.
  bool isValid() const;
};

// The reference's per-frame gains, shared by all motors: a_r at each point and direction (Q16),
// and where the points lie (point i at force i << bin_shift dg, bin_shift >= 1; the interval a
// force is in and its place in it from one multiplication by bin_scale_q16 = 2^(16 - bin_shift);
// at and beyond point kShaperBins the last point's value).
struct ShaperReferenceTable {
  uint8_t fixed = 0;  // 1: a fixed reference, a_r the same at every point (the frame reads point 0)
  uint8_t bin_shift = 1;
  uint16_t bin_scale_q16 = 0x8000;
  uint16_t a_ref_q16[2][kShaperPoints] = {};
};

// One motor's shaping state and gains.
class DynShaper {
 public:
  // Tabulates this motor's gains against `table` for frames of 1 / frame_hz. `dynamics` not
  // present (or not valid): the motor is not shaped. The reference restarts at `force_dg` (the
  // motor assumed settled at its present command).
  void configure(const MotorDynamics& dynamics, const ShaperReferenceTable& table, uint16_t frame_hz,
                 uint16_t force_dg);
  void disable() { active_ = false; }
  bool isActive() const { return active_; }

  // One frame: the force to command now (decigrams) for the requested `force_dg`, the model
  // making at most `max_dg`. Not active: `force_dg` unchanged.
  uint16_t step(uint16_t force_dg, uint16_t max_dg, const ShaperReferenceTable& table);
  // Every motor's frame in one call: out_dg[i] = shapers[i]->step(force_dg[i], max_dg[i], table).
  // The same results; on the AVR the registers are saved once a frame, not once a motor.
  static void stepAll(DynShaper* const* shapers, const uint16_t* force_dg, const uint16_t* max_dg, uint16_t* out_dg,
                      uint8_t count, const ShaperReferenceTable& table);

  // The reference's present value, decigrams (what the motor's force is expected to be).
  uint16_t referenceDg() const { return static_cast<uint16_t>((ref_q8_ + 128) >> 8); }
  // The table entries (tests, status) at point 0..kShaperBins: a_r / a_m in Q14, a_m in Q16.
  uint16_t gainQ14(uint8_t dir, uint8_t point) const { return gain_q14_[dir][point]; }
  uint16_t motorQ16(uint8_t dir, uint8_t point) const { return a_motor_q16_[dir][point]; }

 private:
  uint16_t frame(uint16_t force_dg, uint16_t max_dg, const ShaperReferenceTable& table);  // step()'s body

  int32_t ref_q8_ = 0;  // the reference, 1/256 dg
  bool active_ = false;
  uint16_t a_motor_q16_[2][kShaperPoints] = {};
  uint16_t gain_q14_[2][kShaperPoints] = {};
};

// The reference table for motors of at most `max_dg` (the points cover 0..max_dg) at `frame_hz`:
// fixed, or the slowest of `count` motors' laws (entries without dynamics skipped). False when
// the reference is slowest and none of the motors has dynamics (nothing to shape), or the
// reference is not valid.
bool buildShaperReference(ShaperReferenceTable& table, const ShaperReference& reference,
                          const MotorDynamics* const* motors, uint8_t count, uint16_t max_dg,
                          uint16_t frame_hz);

// Per-frame gain 1 - exp(-dt / tau) in Q16 for a frame of 1 / frame_hz (tests, tables).
uint16_t frameGainQ16(float tau_s, uint16_t frame_hz);

}  // namespace tc

// The mixer: a collective force and a torque about each axis -> the force of each motor, in
// grams, within what the motors can make. Motor positions and spins as the simulated airframe
// has them (tools/plant/include/plant/gimbal.hpp; ESC output i drives motor i), body x forward,
// y left, z up; spin +1 counter-clockwise seen from above:
//   plus:   0 front (+a, 0) CCW, 1 left (0, +a) CW, 2 rear (-a, 0) CCW, 3 right (0, -a) CW
//   X:      0 front-left CCW, 1 rear-left CW, 2 rear-right CCW, 3 front-right CW, a / sqrt 2 out
//   seesaw: 0 left (0, +a), 1 right (0, -a); motors 2 and 3 stopped (roll only)
// Motor i at (x, y) pushing F along z makes (y F, -x F, -spin kq F) about x, y, z, kq = Q/T
// (the propeller's torque per thrust, about 15 mm for a 9x4.7: docs/fly.md). The mixer inverts
// that: F_i = T/n + sx_i Tx/lever + sy_i Ty/lever + sz_i Tz/(n kq), lever = 2a (plus, seesaw) or
// 2 sqrt(2) a (X).
// Saturation keeps attitude authority, in this order: roll and pitch first (their spread is
// scaled down only if it alone exceeds the motors' range, and yaw is then dropped), yaw next
// (scaled so the spread fits), the collective last (shifted to fit). mix() says what it gave
// up (MixLimit bits), so the controller holds those integrators.
// Forces are fixed point, decigrams in an int32 (ForceDg): the torques come in the mixer's units
// (TorqueDg, the controller's fixed-point output; mix() rounds torques in N m to them), and the
// spreads, clamps and sums that follow are integer.
// A stage of fly's loop: TorqueDg in, Forces out (flight_types.hpp, where the units are); it
// depends on no other stage.
#pragma once
#include <stdint.h>

#include "flight_types.hpp"

namespace fly {

enum class Layout : uint8_t { kPlus, kX, kSeesaw };

constexpr float kDefaultArmM = 0.225f;      // the Iqarus and the simulated airframe
constexpr float kDefaultYawArmM = 0.0149f;  // Q/T of an APC 9x4.7: C_P D / (2 pi C_T)

// The airframe as the mixer sees it, one plain struct (fly's parameters point at it).
struct MixerSettings {
  Layout layout = Layout::kX;
  float arm_m = kDefaultArmM;          // centre to each motor
  float yaw_arm_m = kDefaultYawArmM;   // the propeller's torque per thrust, Q/T
};

class Mixer {
 public:
  Mixer() { configure(MixerSettings()); }
  void configure(const MixerSettings& settings);
  const MixerSettings& settings() const { return settings_; }
  Layout layout() const { return settings_.layout; }
  uint8_t motorMask() const { return layout() == Layout::kSeesaw ? 0x03 : 0x0F; }  // ESC outputs flown
  uint8_t motorCount() const { return layout() == Layout::kSeesaw ? 2 : 4; }
  bool flies(uint8_t motor) const { return (motorMask() >> motor) & 1u; }

  // Decigrams on each motor per N m of roll or pitch torque, and per N m of yaw torque: the
  // controller's torques in the mixer's units (AttitudeController::setForceScale).
  float dgPerNmXy() const { return dg_per_nm_xy_; }
  float dgPerNmZ() const { return dg_per_nm_z_; }

  // The four forces for `collective` (per motor) and `torque`, each flown motor's within
  // [min, max] (0 for the others); returns MixLimit bits.
  uint8_t mix(ForceDg collective, const Torque& torque, ForceDg min, ForceDg max, Forces& force) const;
  // The same for a torque already in the mixer's units (the frame path: integer only).
  uint8_t mixDg(ForceDg collective, const TorqueDg& torque, ForceDg min, ForceDg max, Forces& force) const;

 private:
  void rollPitch(ForceDg x, ForceDg y, ForceDg (&rp)[4]) const;
  uint8_t fit(const ForceDg (&rp)[4], ForceDg z, ForceDg range, ForceDg (&e)[4], ForceDg& lo,
              ForceDg& hi) const;

  MixerSettings settings_;
  float dg_per_nm_xy_ = 0;  // decigrams on each motor per N m of roll or pitch torque
  float dg_per_nm_z_ = 0;   // per N m of yaw torque
};

}  // namespace fly

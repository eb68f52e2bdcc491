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
// Forces are fixed point, 1/16 g in an int32 (ForceQ4): the torques come in the mixer's units
// (TorqueQ4, the controller's fixed-point output; mix() rounds torques in N m to them), and the
// spreads, clamps and sums that follow are integer; force and pwm modes never go back to float.
#pragma once
#include <stdint.h>

#include "controller.hpp"

namespace fly {

enum class Layout : uint8_t { kPlus, kX, kSeesaw };

using ForceQ4 = int32_t;  // grams * 16
constexpr int32_t kQ4PerGram = 16;
inline ForceQ4 toQ4(float grams) {  // rounded; |grams| well within +-100,000
  const float q = grams * kQ4PerGram;
  return static_cast<ForceQ4>(q < 0 ? q - 0.5f : q + 0.5f);
}
inline float gramsOf(ForceQ4 force) { return static_cast<float>(force) * (1.0f / kQ4PerGram); }
inline int32_t roundedGrams(ForceQ4 force) { return (force + kQ4PerGram / 2) >> 4; }

constexpr float kDefaultArmM = 0.225f;      // the Iqarus and the simulated airframe
constexpr float kDefaultYawArmM = 0.0149f;  // Q/T of an APC 9x4.7: C_P D / (2 pi C_T)

class Mixer {
 public:
  Mixer() { configure(Layout::kX, kDefaultArmM, kDefaultYawArmM); }
  void configure(Layout layout, float arm_m, float yaw_arm_m);
  Layout layout() const { return layout_; }
  uint8_t motorMask() const { return layout_ == Layout::kSeesaw ? 0x03 : 0x0F; }  // ESC outputs flown
  uint8_t motorCount() const { return layout_ == Layout::kSeesaw ? 2 : 4; }
  bool flies(uint8_t motor) const { return (motorMask() >> motor) & 1u; }

  // 1/16 g on each motor per N m of roll or pitch torque, and per N m of yaw torque: the
  // controller's torques in the mixer's units (AttitudeController::setForceScale).
  float q4PerNmXy() const { return q4_per_nm_xy_; }
  float q4PerNmZ() const { return q4_per_nm_z_; }

  // The four forces for `collective` (per motor) and `torque`, each flown motor's within
  // [min, max] (0 for the others); returns MixLimit bits.
  uint8_t mix(ForceQ4 collective, const Torque& torque, ForceQ4 min, ForceQ4 max, ForceQ4 (&force)[4]) const;
  // The same for a torque already in the mixer's units (the frame path: integer only).
  uint8_t mixQ4(ForceQ4 collective, const TorqueQ4& torque, ForceQ4 min, ForceQ4 max, ForceQ4 (&force)[4]) const;

 private:
  void rollPitch(ForceQ4 x, ForceQ4 y, ForceQ4 (&rp)[4]) const;
  uint8_t fit(const ForceQ4 (&rp)[4], ForceQ4 z, ForceQ4 range, ForceQ4 (&e)[4], ForceQ4& lo,
              ForceQ4& hi) const;

  Layout layout_ = Layout::kX;
  float q4_per_nm_xy_ = 0;  // 1/16 g on each motor per N m of roll or pitch torque
  float q4_per_nm_z_ = 0;   // per N m of yaw torque
};

}  // namespace fly

// The force model one motor slot flies, in one piece of SRAM: either the thesis calibration
// (layout v1: two 500-gram curves and the sag table, 1114 bytes on the AVR, flown with option
// 2.1) or model v2 (force in effective motor voltage, 123 bytes). A slot holds one or the
// other, never both, so the two share their storage (a union): four slots cost what four v1
// calibrations cost, whatever mix of layouts the EEPROM holds.
//
// Which member is alive is explicit: holdsV2(). v1() and v2() may only be called for the
// member that is alive (callers check holdsV2() first; Motor::fliesV2() does).
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "thrustcal/model_v2.hpp"
#include "thrustcal/motor_calibration.hpp"

#if defined(__AVR__)
// avr-libc ships no <new>; this is the standard placement form (construct at an address).
inline void* operator new(size_t, void* where) noexcept { return where; }
#else
#include <new>
#endif

namespace rr {

class SlotModel {
 public:
  SlotModel() : v1_() {}
  SlotModel(const SlotModel&) = delete;
  SlotModel& operator=(const SlotModel&) = delete;

  // Makes the thesis calibration the live member, cleared (not calibrated), and returns it
  // so a loader can fill it in place.
  tc::MotorCalibration& resetToV1() {
    new (&v1_) tc::MotorCalibration();
    holds_v2_ = false;
    return v1_;
  }
  // Makes model v2 the live member, a copy of `model`.
  void setV2(const tc::ModelV2& model) {
    new (&v2_) tc::ModelV2(model);
    holds_v2_ = true;
  }

  bool holdsV2() const { return holds_v2_; }
  const tc::MotorCalibration& v1() const { return v1_; }
  const tc::ModelV2& v2() const { return v2_; }

 private:
  // Both members are trivially destructible: re-constructing over either ends the other.
  union {
    tc::MotorCalibration v1_;
    tc::ModelV2 v2_;
  };
  bool holds_v2_ = false;
};

}  // namespace rr

// The force model one motor slot flies, in one piece of SRAM: either the thesis model (layout v1,
// tc::ThesisRun: option 2.1 with the curves' PWM steps read from the EEPROM on demand) or
// model v2 (tc::ModelV2Run, the model as the frame reads it). A slot holds one or the other,
// never both, so the two share their storage (a union): four slots stay under 1 KB whatever
// mix of layouts the EEPROM holds, where four decoded thesis records would not fit the SRAM.
// fw::ForceActuators keeps one per motor; `thrustcal bench footprint` measures its size on the AVR
// (docs/results.md). In core, so the bench's AVR probe can use it too.
//
// Which member is alive is explicit: holdsV2(). v1() and v2() may only be called for the
// member that is alive (callers check holdsV2() first; fw::Motor::fliesV2() does).
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "thrustcal/placement_new.hpp"
#include "thrustcal/model_v2_runtime.hpp"
#include "thrustcal/thesis_runtime.hpp"

namespace tc {

class SlotModel {
 public:
  SlotModel() : v1_() {}
  SlotModel(const SlotModel&) = delete;
  SlotModel& operator=(const SlotModel&) = delete;

  // Makes the thesis model the live member, loaded from the record of `slot` decoded into
  // `cal` (its steps stay in Storage). False: the EEPROM no longer holds what was decoded
  // (the member is then cleared: not calibrated).
  template <class Storage>
  bool setV1(const tc::MotorCalibration& cal, uint8_t slot) {
    new (&v1_) tc::ThesisRun();
    holds_v2_ = false;
    return v1_.load<Storage>(cal, slot);
  }
  // Makes model v2 the live member, rebuilt from `model` for the frame. False: no model.
  bool setV2(const tc::ModelV2& model) {
    new (&v2_) tc::ModelV2Run();
    holds_v2_ = true;
    return v2_.load(model);
  }
  void clear() {
    new (&v1_) tc::ThesisRun();
    holds_v2_ = false;
  }

  bool holdsV2() const { return holds_v2_; }
  const tc::ThesisRun& v1() const { return v1_; }
  const tc::ModelV2Run& v2() const { return v2_; }

 private:
  // Both members are trivially destructible: re-constructing over either ends the other.
  union {
    tc::ThesisRun v1_;
    tc::ModelV2Run v2_;
  };
  bool holds_v2_ = false;
};

}  // namespace tc

// The store decision of gather_store (thesis "First or second?", fig. 6.8, and model v2's
// fit-or-refine rule): pure functions over the last sweep and what the slot holds. No console,
// no EEPROM: the store commands (GatherStoreApp::cmdStore / cmdStoreV2 in gather_store_app.cpp)
// read the slot, ask these, write through
// thrustcal/eeprom_store.hpp (which picks the copy to write and keeps the old calibration
// loadable meanwhile) and hand the outcome to the view (gather_store_view.cpp). The host tests
// (tests/firmware/gather_store/test_store_decision.cpp) check the rules without a console.
#pragma once
#include <stdint.h>

#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace gs {

struct SweepResult;

// Why a store is refused (kNone: go ahead). Every refusal changes nothing.
enum class StoreRefusal : uint8_t {
  kNone = 0,
  kNoSweep,          // no complete sweep kept
  kOtherSlot,        // the sweep was measured on another slot than the selected one
  kNoThesisCurve,    // store 1|2: the sweep built no thesis curve
  kSlotHoldsV2,      // store 2: the slot holds model v2, not a curve 1
  kNoFirstCurve,     // store 2: the slot holds no valid record
  kVoltagesTooClose, // store 2: this sweep started too near curve 1's start voltage
  kTooManySamples,   // store v2: the sweep has more steps than the fitter keeps
  kFitUnusable,      // store v2: the sweep cannot give a model (too few steps, no force, volts)
  kRefinedNear,      // store v2: the slot's model was refined by a sweep near this one
};

// A complete sweep on the selected slot (checked before anything else is read).
StoreRefusal checkStoreSource(const SweepResult& sweep, uint8_t selected_slot);

// store 1 / store 2 (`which`): `record` holds what readRecord gave (`before`); on kNone it holds
// the record to write (curve 1 + sag offsets, keeping curve 2; or curve 2 next to curve 1).
// `slot_holds_v2`: the slot's layout is model v2; `min_span_mv`: the smallest start-voltage
// difference between the two thesis curves (tc::ForcePwmLimits).
StoreRefusal planStoreV1(uint8_t which, const SweepResult& sweep, bool slot_holds_v2,
                         tc::DecodeStatus before, uint16_t min_span_mv,
                         tc::MotorCalibration& record);

// What the slot holds before a store v2.
struct SlotContents {
  bool has_v2 = false;     // a valid model v2 record
  bool has_v1 = false;     // a thesis record (version byte 1) instead
  bool refined = false;    // the model v2 was refined already (tc::kV2Refined)
  uint16_t rest_mv = 0;    // its first sweep's resting voltage
  uint16_t second_mv = 0;  // the refining sweep's (0: none)
  uint16_t start_q4_us = 0;
};

enum class V2Action : uint8_t {
  kFit,     // the model fitted from this sweep alone replaces what the slot holds
  kRefine,  // refine the slot's model with this sweep
  kRefuse,  // kRefinedNear: the slot's model was refined near this sweep's voltage already
};

// The fit-or-refine rule (gather_store_app.hpp): a slot's v2 model from a sweep at least
// `gap_mv` away is refined; one within `gap_mv` is replaced; a refined one whose second sweep
// lies within `gap_mv` (and its first does not) refuses.
V2Action decideV2(const SlotContents& slot, uint16_t sweep_rest_mv, uint16_t gap_mv);

// Whether the fitter's answer to this sweep alone rules model v2 out (the sweep itself is
// unusable) rather than only the model failing (which the fit-or-refine step reports).
bool fitRulesOutSweep(tc::FitV2Status status);

// The smallest PWM step (us) that keeps a sweep over span_us within `capacity` samples.
uint16_t smallestStepUs(uint16_t span_us, uint16_t capacity);

}  // namespace gs

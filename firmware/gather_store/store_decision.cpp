// The store decision (see store_decision.hpp): rules only, no console, no EEPROM.
#include "store_decision.hpp"

#include "gather_store_app.hpp"

namespace gs {

namespace {

uint16_t distanceMv(uint16_t a, uint16_t b) {
  return static_cast<uint16_t>(a > b ? a - b : b - a);
}

}  // namespace

StoreRefusal checkStoreSource(const SweepResult& sweep, uint8_t selected_slot) {
  if (!sweep.complete) return StoreRefusal::kNoSweep;
  if (sweep.slot != selected_slot) return StoreRefusal::kOtherSlot;
  return StoreRefusal::kNone;
}

StoreRefusal planStoreV1(uint8_t which, const SweepResult& sweep, bool slot_holds_v2,
                         tc::DecodeStatus before, uint16_t min_span_mv,
                         tc::MotorCalibration& record) {
  if (!sweep.valid) return StoreRefusal::kNoThesisCurve;
  if (which == 1) {
    if (before != tc::DecodeStatus::kOk) record.clear();
    record.first = sweep.curve;
    record.sag = sweep.sag;
    return StoreRefusal::kNone;
  }
  if (slot_holds_v2) return StoreRefusal::kSlotHoldsV2;
  if (before != tc::DecodeStatus::kOk) return StoreRefusal::kNoFirstCurve;
  if (distanceMv(sweep.curve.start_mv, record.first.start_mv) < min_span_mv)
    return StoreRefusal::kVoltagesTooClose;
  record.second = sweep.curve;
  return StoreRefusal::kNone;
}

V2Action decideV2(const SlotContents& slot, uint16_t sweep_rest_mv, uint16_t gap_mv) {
  const bool near_first = distanceMv(sweep_rest_mv, slot.rest_mv) < gap_mv;
  const bool near_second = distanceMv(sweep_rest_mv, slot.second_mv) < gap_mv;
  if (slot.has_v2 && slot.refined && near_second && !near_first) return V2Action::kRefuse;
  return slot.has_v2 && !near_first ? V2Action::kRefine : V2Action::kFit;
}

bool fitRulesOutSweep(tc::FitV2Status status) {
  return status == tc::FitV2Status::kTooFewSamples || status == tc::FitV2Status::kNoForce ||
         status == tc::FitV2Status::kBadVoltage;
}

uint16_t smallestStepUs(uint16_t span_us, uint16_t capacity) {
  const uint16_t gaps = static_cast<uint16_t>(capacity - 1u);
  return static_cast<uint16_t>((static_cast<uint32_t>(span_us) + gaps - 1u) / gaps);
}

}  // namespace gs

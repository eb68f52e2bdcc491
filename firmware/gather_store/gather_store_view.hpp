// The console view of gather_store: every line the sweep, store, show and status commands
// print, from the data they hand over (no decisions here, no EEPROM writes). Strings are
// TC_FLASH_TEXT literals, so they stay in flash on the AVR.
#pragma once
#include <stdint.h>

#include "gather_store_app.hpp"
#include "store_decision.hpp"
#include "thrustcal/dynamics_fit.hpp"
#include "thrustcal/eeprom_store.hpp"
#include "thrustcal/record_v2.hpp"

namespace gs {
namespace view {

// "; wrote N bytes" + newline
void sayWritten(uint16_t bytes);
// 1/16 us -> "1083.4 us"
void printQ4Us(uint16_t q4_us);
// "EEPROM 0..1023"
void printRecordRange(uint8_t slot);
// "motor N (EEPROM a..b): "
void sayMotorRecord(uint8_t slot);
void printFitProblem(tc::FitV2Status status);
void printBuildProblem(tc::BuildStatus status);  // ends the line
// "curve 1: start 12.600 V, 1..500 g; PWM per gram: 1 g 1105 us, 100 g 1310 us, ..."
void printCurve(uint8_t which, const tc::ForceCurveBase& curve);
// After a store: how it kept the old calibration through a power cut (or that it could not).
void sayStoreSafety(const tc::StoreReport& report, uint8_t slot);

// Sweep lines: the CSV row, the progress line, the summary.
void printCsvRow(uint16_t pwm_us, int16_t force_dg, uint16_t vbat_mv, uint32_t t_ms,
                 uint8_t slot);
void sayProgress(uint16_t done, uint16_t planned, int16_t max_force_dg);
void saySweepSummary(const SweepResult& sweep, uint32_t elapsed_ms);
// "# lag correction: largest shift of a reading X g"
void sayLagCorrected(int16_t largest_dg);

// What a refusal to store says; the facts the message needs.
struct RefusalFacts {
  uint8_t slot = 0;                 // the selected slot
  tc::DecodeStatus before = tc::DecodeStatus::kOk;  // kNoFirstCurve: what the slot held
  uint16_t other_mv = 0;            // kVoltagesTooClose: curve 1's start; kRefinedNear: 2nd sweep
  uint16_t this_mv = 0;             // kVoltagesTooClose / kRefinedNear: this sweep's voltage
  uint16_t limit = 0;               // kVoltagesTooClose: span in mV; kTooManySamples: capacity
  uint16_t step_us = 0;             // kTooManySamples: the smallest step that fits
  tc::FitV2Status fit = tc::FitV2Status::kOk;  // kFitUnusable
};
void sayRefusal(StoreRefusal why, const SweepResult& sweep, const RefusalFacts& facts);

// store 1|2 after the write: stored (with what it holds now) or why not.
// (The outcome structs hold no tc::StoreReport: a local with its non-zero defaults would be
// initialized from a constant copy, which the AVR keeps in SRAM.)
struct V1Outcome {
  uint8_t which = 0;
  uint8_t slot = 0;
  bool had_v2 = false;
  tc::DecodeStatus after = tc::DecodeStatus::kOk;  // the read-back
  uint16_t written = 0;
};
void sayV1Outcome(const V1Outcome& outcome, const tc::StoreReport& report,
                  const SweepResult& sweep, const tc::MotorCalibration& record);

// store v2: fitting or refining failed / the write's outcome.
void sayV2FitFailed(uint8_t slot, bool refine, tc::FitV2Status status);
struct V2Outcome {
  uint8_t slot = 0;
  bool refine = false;
  SlotContents before;
  uint16_t rest_mv = 0;  // this sweep's resting voltage
  uint16_t written = 0;
};
void sayV2Outcome(const V2Outcome& outcome, const tc::StoreReport& report,
                  const tc::ModelV2& model);

// dyn and dyn cell (dynamics_view.cpp; the step log's format: docs/gather_store.md).
void sayDynHeader();  // the CSV header
// The log's rows: t_s since `session_us`, the pulse the ESC flew then, force, bus, slot, dir.
void printDynRows(const DynLog& log, const DynRecording& rec, uint32_t session_us, uint8_t slot, int8_t dir);
void sayDynStep(int8_t dir, const DynRecording& rec, uint32_t session_us, uint16_t vbat_mv);
void sayDynFit(int8_t dir, const DynRecording& rec, const tc::MotorStepFit& fit);
void sayCellFit(const tc::BenchStepFit& fit);
void sayCellStored(const tc::BenchResponse& bench, const tc::SettingsWrite& w);
// dyn's preconditions, each refusal with what to do. True: it may run.
bool dynMayRun(bool tared, const tc::BenchResponse& bench, tc::DecodeStatus v2, uint8_t slot);
void sayDynPlan(uint8_t slot, uint16_t max_force_dg, const tc::BenchResponse& bench, uint16_t lo_us,
                uint16_t hi_us);
void sayDynFailed(uint8_t slot, uint8_t points_ok);
void sayDynStored(uint8_t slot, const tc::MotorDynamics& d, uint32_t session_ms, const tc::StoreReport& report);
// "3 stages of 30.0 ms (mean delay 90.0 ms)"
void printBenchResponse(const tc::BenchResponse& bench);
// "5 points 90.1..449.8 g: spin-up 91.2 -> 74.0 ms, spin-down 92.0 -> 74.9 ms"
void printDynamics(const tc::MotorDynamics& d);

// show
void showModelV2(uint8_t slot, const tc::RecordV2Read& read, const tc::ModelV2& model);
void showRecordV1(uint8_t slot, tc::DecodeStatus status, const tc::Plausibility& why,
                  const tc::MotorCalibration& record);

}  // namespace view
}  // namespace gs

// Gather and Store (thesis sec. 6.4, fig. 6.8, appendix G): the bench-side program, as a
// serial console (115200 8N1, prompt "gs> ").
//
// Flow (fig. 6.8): choose the motor slot -> phase 1, weigh: calibrate with the known weight of
// motor + propeller (plate excluded) -> phase 2, zerolize (tare) -> sweep the PWM range: per
// step wait `settle` ms, read force (median of 201) and battery (median of 101) -> filter
// functions: force curve (PWM per gram, 1..500 g) and battery sag offsets (40 us bins) ->
// "first or second?": store the first curve with its start voltage and offsets, or the second
// curve, in the slot's EEPROM record (read-modify-write).
//
// Beyond the thesis: `store v2` fits model v2 (thrustcal/model_v2.hpp: force as a curve in
// effective motor voltage (pwm - start) * V_bus) from the same sweep ON THE BOARD and writes
// it as the two-copy, power-fail-safe v2 record (thrustcal/record_v2.hpp). The sweep keeps
// (pwm_us, force_dg, vbat_mv) of every step for it (kMaxV2Samples, 8 bytes each). What
// `store v2` does depends on what the slot holds:
//   - nothing, a thesis (v1) record, or a v2 model whose first sweep rested within 0.5 V of
//     this one: the model fitted from this sweep alone replaces it;
//   - a v2 model from a sweep at a clearly different resting voltage (>= 0.5 V apart): it is
//     REFINED with this sweep (start threshold measured from both, knots averaged), so the
//     thesis workflow "sweep on the LiPo, store v2, sweep at another voltage, store v2" ends
//     with a refined model;
//   - a model already refined by a sweep within 0.5 V of this one: refused (refining twice
//     with the same voltage would count that sweep double); erase first to start over.
// `store 1` / `store 2` onto a slot holding v2 replace it with the thesis record. Every
// store and erase prints how many EEPROM bytes it physically wrote (bytes that already
// hold their value are skipped).
//
// Stores go through thrustcal/eeprom_store.hpp: a switch between the thesis record and model v2
// keeps the old calibration loadable until the new one is complete (a copy in another slot),
// so a power cut at any byte leaves the old or the new one; with no slot to spare (the other
// three hold thesis records) the switch says it is unprotected. A record that cannot be right
// (thrustcal/plausibility.hpp) is never stored, and `show` says which rule a stored one breaks.
// The battery monitor's divider is a board setting (`divider`, default 100k/47k, stored in
// EEPROM and shared with read_run): the sweep's volts come through it.
//
// SRAM (avr-size, MinSizeRel): 5295 bytes static (the sweep's curve builder and store's / show's
// record share one union, Scratch; model v2 adds 1030 bytes of fitter work space for 128
// samples and the 124-byte ModelV2 buffer); `thrustcal bench footprint` measures the stack
// left after the deepest paths in simavr.
//
// Console rules:
//  - errors are one line starting "error: " that says what was wrong and what to do; a
//    rejected command changes nothing;
//  - during a sweep every line that is not CSV starts with "# ", so a captured log is a CSV
//    file with comments (header `pwm_us,force_g,vbat_v,t_s,motor,dir`, once per sweep);
//  - any byte received during a sweep aborts it: the motor goes to 1000 us before anything
//    is printed; the rest of that key's line is discarded (docs/console.md), so "xerase"
//    typed during a sweep erases nothing. A load-cell overload (> 950 g), a reading at the
//    ADC rail or a battery reading outside the pack range (3 V .. the smaller of 26 V and the
//    divider's full scale) aborts it too;
//  - the line protocol (checksum *HH, strict on|off, damaged lines rejected whole) is
//    fw::LineReader's; the watchdog is kicked by the main loop and inside every long wait.
//
// Motor slot N (0..3) drives ESC output N (D6, D7, D8, D11) and is stored at EEPROM N * 1024.
// Host tests drive this class against the fake HAL; main.cpp is the AVR-only part.
#pragma once
#include <stdint.h>

#include "console.hpp"
#include "shell.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/board_settings.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/dynamics_fit.hpp"
#include "thrustcal/sweep_lag.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/force_curve.hpp"
#include "thrustcal/limits.hpp"
#include "thrustcal/load_cell.hpp"
#include "thrustcal/median_filter.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/motor_calibration.hpp"
#include "thrustcal/placement_new.hpp"
#include "thrustcal/sweep_limits.hpp"
#include "thrustcal/sweep_rules.hpp"

namespace gs {

enum class StoreRefusal : uint8_t;  // store_decision.hpp
namespace view {
struct RefusalFacts;  // gather_store_view.hpp
}  // namespace view

using tc::kArmMs;       // thrustcal/limits.hpp
using tc::kStopPwmUs;
// The sweep's reading and settle auto (thrustcal/sweep_rules.hpp, shared with the bench): with
// settle auto the force and the tare are the central mean of the 201 readings; steps end,
// rails and overloads are still judged on the median; `settle MS` keeps the thesis's median.
using tc::kForceWindow;
using tc::kForceCentral;
using tc::kBatteryWindow;
constexpr uint16_t kMaxSweepSamples = 161; // 1000..1800 us in 5 us steps; default uses 81
// Samples model v2 keeps per sweep: 8 bytes each in SRAM (1 KB). A sweep with more steps
// still measures and stores the thesis curves; `store v2` refuses it.
constexpr uint16_t kMaxV2Samples = 128;
using tc::kV2MinVoltageGapMv;
constexpr uint8_t kProgressEvery = 10;     // one "# " progress line per this many samples
constexpr uint8_t kLineEndGraceMs = 3;     // an LF this soon after "sweep" CR is its line end

// The settings' accepted ranges: thrustcal/sweep_limits.hpp.

using tc::kSettleProbeMs;  // settle auto: thrustcal/sweep_rules.hpp
using tc::kSettledCounts;
using tc::kSettledAgreements;

using tc::kDefaultSettleCapMs;  // settle auto's cap by default (thrustcal/sweep_rules.hpp)

struct SweepSettings {
  uint8_t slot = 0;             // motor slot 0..3 = ESC output and EEPROM record
  int16_t plate_g = 60;         // plate carrying the motor (thesis 60 g)
  uint16_t pwm_min_us = tc::kThrottleMinUs;  // sweep start
  uint16_t pwm_max_us = 1800;   // sweep end (inclusive when on the step grid)
  uint16_t step_us = 10;
  uint16_t settle_ms = kDefaultSettleCapMs;  // per step (settle auto: the cap); thesis 200
  bool settle_auto = true;      // step on once the force stops changing (settle MS: off)
};

// dyn and dyn cell (dynamics_runner.cpp): one step log, blocks of tc::kDynBlockConversions
// load-cell conversions and one battery conversion (about 1.8 ms): 0.05 s before a step and
// 0.6 s after it, enough for the slowest motor and the load cell's filter to settle.
constexpr uint16_t kDynLogBlocks = 360;
constexpr uint16_t kDynPreBlocks = 30;
struct DynLog {
  int16_t force_dg[kDynLogBlocks];                         // mean force per block
  uint16_t vbat_mv[kDynLogBlocks / tc::kDynBlocksPerVbat];  // bus, mean of 4 blocks
};

// Work space no two commands use at once, in one union (1.1 KB of SRAM less): the curve
// builder of a sweep (from `sweep` to its summary), the record buffer of store and show
// (read-modify-write), a step log of dyn. start...() constructs the member a command is about
// to use.
class Scratch {
 public:
  Scratch() : record_() {}
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  tc::CurveBuilderBase& startBuilder() {
    new (&builder_) tc::CurveBuilder<kMaxSweepSamples>();
    return builder_;
  }
  tc::CurveBuilderBase& builder() { return builder_; }
  tc::MotorCalibration& startRecord() {
    new (&record_) tc::MotorCalibration();
    return record_;
  }
  tc::MotorCalibration& record() { return record_; }
  DynLog& startDynLog() {
    new (&dyn_) DynLog();
    return dyn_;
  }

 private:
  // The members are trivially destructible: constructing over one ends the others.
  union {
    tc::CurveBuilder<kMaxSweepSamples> builder_;
    tc::MotorCalibration record_;
    DynLog dyn_;
  };
};
static_assert(sizeof(DynLog) <= sizeof(tc::CurveBuilder<kMaxSweepSamples>), "a step log must not grow the scratch space");

// One recorded step log: when it ran (Clock::micros), where its step is.
// The step's instant is kept on the log's own grid (the block it was written before, and the
// rest of that ESC frame plus the new width), so it and the blocks share one time base.
struct DynRecording {
  uint32_t start_us = 0;  // the first conversion
  uint32_t end_us = 0;    // after the last
  uint16_t step_block = 0;       // the pulse was written as this block began (0: no step)
  uint16_t edge_after_us = 0;    // from that write to the ESC's falling edge that carried it
  uint32_t edge_us = 0;   // that edge on Clock::micros (0: no step)
  uint16_t from_us = 0, to_us = 0;
  float blockS() const { return static_cast<float>(end_us - start_us) * 1e-6f / kDynLogBlocks; }
  float stepS() const { return static_cast<float>(step_block) * blockS() + static_cast<float>(edge_after_us) * 1e-6f; }
};

// Why a sweep ended.
enum class SweepEnd : uint8_t {
  kDone = 0,
  kKey,          // a byte arrived on the UART
  kOverload,     // |load| above 950 g
  kImplausible,  // load-cell ADC at a rail
  kBattery,      // battery reading outside the sane range
};

// What the last sweep left for `store`.
struct SweepResult {
  bool valid = false;            // a completed sweep whose curve was built
  bool complete = false;         // the sweep ran to its end (model v2 may still fit it)
  uint8_t slot = 0;              // the slot it was measured on
  uint16_t samples = 0;
  tc::BuildReport report;
  tc::ThesisCurve curve;         // start_mv = average battery of the first 40 us bin
  tc::SagTable sag;
  bool lag_corrected = false;    // a fixed-settle sweep corrected with the slot's dynamics
};

// From writing a pulse now to the ESC's falling edge that carries it: the rest of this frame
// and the new width (the compare registers are double-buffered). dynamics_runner.cpp.
uint16_t escEdgeAfterWriteUs(uint16_t pwm_us);

class GatherStoreApp {
 public:
  GatherStoreApp();
  GatherStoreApp(const GatherStoreApp&) = delete;
  GatherStoreApp& operator=(const GatherStoreApp&) = delete;

  // Arms the ESCs (1000 us on all four), prints the banner and the first prompt.
  void begin();
  // Handles at most one complete command line from the UART (non-blocking when none is
  // there; a sweep blocks until it ends). Returns true when a line was handled.
  bool poll();

  // Observers for tests.
  const SweepSettings& sweepSettings() const { return sweep_settings_; }
  const tc::LoadCell& loadCell() const { return cell_; }
  const SweepResult& lastSweep() const { return sweep_; }
  SweepEnd lastSweepEnd() const { return last_end_; }

 private:
  friend struct GatherStoreCommands;  // the command table's handlers (gather_store_commands.cpp)

  void execute(char* line);
  void runCommand(char* line, const fw::LineContext& context);  // through the table
  void prompt();

  // Commands (arguments parsed and range-checked by the table).
  void cmdHelp();
  void cmdMotor(uint8_t slot);
  void cmdPlate(int16_t grams);
  void cmdWeigh();
  void cmdTare();
  void cmdCal(int16_t grams);
  void cmdSpan(int16_t grams);
  void cmdRange(uint16_t lo_us, uint16_t hi_us);
  void cmdStep(uint16_t step_us);
  void cmdSettle(uint16_t ms);
  void cmdSettleAuto();
  void cmdSweep();
  void cmdStore(uint8_t which);  // store 1 | store 2
  void cmdStoreV2();
  void cmdShow();
  void cmdErase();
  void cmdStatus();
  void cmdDividerShow();
  void cmdDivider(uint32_t top_ohm, uint32_t bottom_ohm);
  void cmdDynCell();
  void cmdDyn();
  void sayPlannedSteps();  // " us, K steps" + newline
  // Prints the refusal and returns true unless `why` is kNone.
  bool refuse(StoreRefusal why, const view::RefusalFacts& facts);
  // Force in 0.1 g from a reading in 1/16 count (rounded).
  int16_t forceDecigrams(uint16_t force_q4) const;

  // Sweep parts.
  uint16_t plannedSamples() const;
  // Consumes the LF of a CR LF line end that arrives within kLineEndGraceMs. False: another
  // byte came instead, which aborts the sweep before the motor starts.
  bool swallowLineFeed();
  // One step: pulse, settle, force and battery medians, checks. False: aborted (the motor
  // is already at 1000 us and the reason printed).
  // start_us: the sweep's start (Clock::micros), the lag correction's time origin.
  bool measureStep(uint16_t pwm_us, uint32_t start_us, int16_t& force_dg, uint16_t& vbat_mv);
  // A fixed-settle sweep of a slot whose record holds dynamics, with the bench's response in the
  // settings: its readings are corrected for the lag (issue 26 item 2). Prints a line when on.
  void startLagCorrection(uint8_t slot);
  // A step's sample into the curve, the sag table and the v2 fitter. A lag-corrected sweep holds
  // it (pending_) until the next step's pulse is out: its correction (float, ~15 ms on the
  // chip) then runs inside that step's settle time instead of after it, with the step's edge
  // and reading times still in step_edge_us_ / step_read_us_.
  void keepSample(const tc::SweepPointV2& raw);
  void keepPendingSample(uint32_t start_us);
  void addToBuilders(const tc::SweepPointV2& p);
  // Builds the curve and the sag table from the samples and prints the summary.
  void finishSweep(uint8_t slot, uint32_t elapsed_ms);
  bool waitOrAbort(uint16_t ms);  // false: a key arrived (motor already stopped)
  // settle auto: waits until the force median stops changing (or the cap) and returns the
  // last median. False: a key arrived.
  bool settleForce(uint16_t& counts);
  void printSettle();  // "settle 200 ms" / "settle auto (cap 200 ms)"
  void printSweepPlan();  // "1000..1800 us, step 10 us, settle auto (cap 500 ms)"
  // false: a key arrived during the 201 readings. centre_us: their middle instant, taken before
  // the median's sort.
  bool readForceCounts(uint16_t& counts, uint32_t& centre_us);
  bool readBatteryCounts(uint16_t& counts);
  void stopMotor();
  // kKey: `value` is the key (a hal::Uart::read() item) or kKeyUnread while it is still in the
  // receiver; the rest of its line is discarded too. Otherwise the reading that aborted.
  static constexpr uint16_t kKeyUnread = 0xFFFF;
  void abortSweep(SweepEnd why, uint16_t value);

  // dyn (dynamics_runner.cpp). One block: its load-cell sum (1/16 count) and battery reading.
  // False: aborted (printed, motor stopped).
  bool readDynBlock(uint16_t& sum_q4, uint16_t& vbat_counts);
  bool storeDynBlock(DynLog& log, uint16_t b, uint16_t sum_q4, uint16_t vbat_counts, uint16_t& vbat_sum);
  // A step log: kDynLogBlocks blocks, `to_us` written at block kDynPreBlocks.
  bool recordStep(DynLog& log, uint16_t to_us, DynRecording& rec);
  // dyn cell: blocks until a weight step is seen, the step kDynPreBlocks * 2 blocks in.
  bool recordCellStep(DynLog& log, DynRecording& rec);
  // One step of dyn: record, print, fit. False: aborted.
  bool dynStep(uint16_t from_us, uint16_t to_us, uint32_t session_us, tc::MotorStepFit& fit);
  tc::StepLog stepLog(const DynLog& log, const DynRecording& rec) const;

  // Readings outside a sweep.
  uint16_t medianForceCounts();
  uint16_t medianBatteryCounts();
  // Median load-cell reading; prints an error and returns false when it sits at an ADC rail.
  bool readSaneCell(uint16_t& counts);
  // Zerolize at the window force_median_ holds (its median is `counts`) and remember the
  // reading for `span`.
  void tareAt(uint16_t counts);
  // The force reading of the window force_median_ holds, in 1/16 count: the central mean with
  // settle auto, the thesis's median otherwise.
  uint16_t forceQ4() const {
    return sweep_settings_.settle_auto ? force_median_.centralMeanQ4(kForceCentral)
                                 : static_cast<uint16_t>(force_median_.median() * 16u);
  }

  SweepSettings sweep_settings_;
  tc::LoadCell cell_;
  tc::BoardSettings board_settings_;  // the divider (EEPROM), read at begin()
  tc::BatteryMonitor battery_;        // configured from it
  uint16_t tare_counts_ = 0;  // load-cell reading at the last tare (the span's empty point)
  uint32_t armed_at_ms_ = 0;

  fw::LineReader reader_;
  SweepEnd last_end_ = SweepEnd::kDone;
  SweepResult sweep_;

  // Work space (static in the AVR image: the app object is a global).
  tc::MedianFilter<kForceWindow> force_median_;
  tc::MedianFilter<kBatteryWindow> battery_median_;
  Scratch scratch_;              // the sweep's curve builder, or store's / show's record
  tc::SagBuilder sag_builder_;
  tc::ModelV2Fitter<kMaxV2Samples> fitter_;  // the sweep's samples for model v2
  tc::ModelV2 model_;            // store v2 / show: the model fitted, refined or read
  // The lag correction of the sweep running (sweep_lag.hpp), the dynamics it uses (kept for
  // store v2), the last step's ESC edge and the centre of its force reading (Clock::micros).
  tc::SweepLagCorrector lag_;
  tc::MotorDynamics lag_dynamics_;
  uint32_t step_edge_us_ = 0, step_read_us_ = 0;
  // The sample held for the lag correction; pwm_us 0: none (a sweep's pulses are >= 1000 us).
  tc::SweepPointV2 pending_ = {0, 0, 0};
};

}  // namespace gs

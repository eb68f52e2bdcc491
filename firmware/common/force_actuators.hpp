// The force API: four calibrated motors as flight code sees them. Load the slots once, then
// command each motor's force in decigrams (0.1 g) and call frame() once per ESC frame; every motor gets
// the pulse that produces its force on *this* motor at the present battery voltage, through
// the model its EEPROM slot holds (thesis option 2.1 for a v1 record, model v2 for a v2 one).
// read_run flies it from console commands, fly from its attitude controller; a user's own
// flight code uses it the same way (docs/fly.md):
//
//   fw::ForceActuators motors;
//   motors.loadSettings();                    // the battery divider (EEPROM)
//   motors.loadSlots(&printSlot);             // the four records, once (thesis H.2)
//   ... every frame:
//   motors.setForceDg(i, force_dg);           // decigrams; armable motors only (isArmable(i))
//   motors.frame();                           // battery, models, four pulses written at once
//   motors.stopAll();                         // 0 g and the stop pulse on every ESC, now
// frame() is sampleBattery() then output(): a loop may read the battery less often than it flies
// (fly reads it every eighth of its 400 Hz frames). setModelSource(i, s) lets motor i fly slot
// s's record (fly's generic mode: one motor's record for all four, what an uncalibrated
// aircraft flies); maxForceDg(i) is the most its model makes (a mixer's saturation limit).
// Forces are decigrams throughout: model v2 flies them as they come, the thesis model between
// its per-gram curve points on the straight line (tc::forceToPwmDg); nothing rounds to grams.
//
// Safety rules kept here: a motor whose model's record did not load whole and plausible is never
// armed (held at the stop pulse, every force to it ignored); the per-frame path is integer only.
// Files: force_actuators.cpp (loading, the frame), frame_rules.hpp (the frame's pure
// decisions); the model a slot flies is tc::SlotModel (core).
#pragma once
#include <stdint.h>

#include "frame_rules.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/board_settings.hpp"
#include "thrustcal/dyn_shaper.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/limits.hpp"
#include "thrustcal/median_filter.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/model_v2_runtime.hpp"
#include "thrustcal/plausibility.hpp"
#include "thrustcal/record_v2.hpp"
#include "thrustcal/slot_model.hpp"

namespace fw {

constexpr uint8_t kNoLane = 0xFF;  // a motor that does not fly v2

// One motor as the thesis's motor_struct: the model loaded from EEPROM plus the state of the
// pulse it was last given.
struct Motor {
  tc::SlotModel model;                           // v1 ThesisRun or v2 ModelV2Run (a union)
  tc::SlotLayout layout = tc::SlotLayout::kNone; // what the slot holds
  tc::DecodeStatus record = tc::DecodeStatus::kErased;  // kOk: `model` is loaded and flown
  uint8_t v2_copy = tc::kNoCopy;                 // v2: copy flown (0 = A, 1 = B)
  tc::DecodeStatus v2_copy_status[2] = {tc::DecodeStatus::kErased, tc::DecodeStatus::kErased};
  uint8_t source = 0;               // the slot whose model this motor flies (its own, unless
                                    // setModelSource chose another)
  uint8_t lane = kNoLane;           // flying a v2 model: its lane in the frame
  tc::Plausibility why;             // record kBadContent: the plausibility rule it broke
  uint16_t force_dg = 0;            // the force command in decigrams: the one place it is kept
  uint16_t shaped_dg = 0;           // what the model flew this frame: force_dg, or shaped by
                                    // equal dynamics (setShaping)
  tc::MotorDynamics dynamics;       // the slot's measured lag (v2 records after `dyn`; none
                                    // for thesis records)
  tc::DynShaper shaper;             // equal dynamics: this motor's filter (setShaping)
  uint16_t pwm_us = tc::kStopPwmUs; // last pulse written to the ESC
  uint16_t vbat_mv = 0;             // voltage used for that pulse: v1 sag-compensated median,
                                    // v2 the bus filter's value
  uint8_t flags = 0;                // tc::ForcePwmFlag bits of that pulse
  uint16_t sag_pwm_us = 0;          // v1: the pulse whose sag offset is kept (0: none yet)
  int16_t sag_offset_mv = 0;        // v1: that offset (its model's sag table at that pulse)

  // The slot's own record (what the start-up report and status describe).
  bool isArmable() const { return record == tc::DecodeStatus::kOk; }
  bool fliesV2() const { return isArmable() && model.holdsV2(); }
};

// The battery as the frame reads it: four conversions of the monitor's pin per frame, into the
// thesis's median of 101 (v1 motors, status) and this frame's own reading (the v2 bus filter's
// input: the mean of the middle two).
class BatteryInput {
 public:
  static constexpr uint8_t kSamplesPerFrame = 4;

  void configure(const tc::BoardSettings& settings) { monitor_ = tc::BatteryMonitor(settings.batteryConfig()); }
  // The frame's four conversions into the median; with `frame_reading`, also this frame's own
  // reading (skipped when no motor flies v2: it is their filter's input only).
  void sample(bool frame_reading);
  uint16_t medianMv() const { return median_mv_; }   // uncompensated
  uint16_t frameMv() const { return frame_mv_; }     // this frame's reading
  bool frameSane() const { return monitor_.isSane(frame_mv_); }
  const tc::BatteryMonitor& monitor() const { return monitor_; }

 private:
  tc::MedianFilter<tc::kBatteryWindow> counts_;
  tc::BatteryMonitor monitor_;
  uint16_t median_mv_ = 0;
  uint16_t frame_mv_ = 0;
};

class ForceActuators {
 public:
  static constexpr uint8_t kMotors = tc::kMotorSlots;
  // Called as each slot loads, with the record it decoded (whichever layout the slot held).
  using SlotReport = void (*)(uint8_t index, const Motor& m, const tc::ModelV2& v2,
                              const tc::MotorCalibration& v1);

  // The board settings (the battery divider) from the EEPROM; counts -> volts and the voltages
  // a record may hold follow them.
  void loadSettings();
  // Thesis H.2: the four records, read once; `report` hears each. Every force is 0 afterwards.
  // Returns how many motors are calibrated (armable).
  uint8_t loadSlots(SlotReport report);
  // After the divider changed: the v2 filters restart (their millivolts came through the old
  // divider); load the settings and the slots again after it.
  void restartFilters();

  static constexpr uint16_t kMaxForceDg = 10u * tc::kRecordMaxForceG;
  // Motor `index`'s force command in decigrams, 0..kMaxForceDg (more is taken as kMaxForceDg).
  // Ignored for a motor that is not armable (it stays at the stop pulse).
  void setForceDg(uint8_t index, uint16_t force_dg);
  // 0 g and the stop pulse on every ESC at once (not waiting for the next frame).
  void stopAll();
  // One ESC frame: sampleBattery(), then output().
  void frame();
  // The battery's readings of a frame (four conversions: the median, the v2 bus reading).
  void sampleBattery();
  // Each motor's pulse from its force through its model at the last readings, the four pulses
  // written back to back: computePulses() then writePulses().
  void output();
  // The two halves of output(), for a loop that times its computation up to the write (fly).
  // writePulses() then prepares the next frame's thesis motors (prepareNextFrame: the sag
  // offset of the pulse written): a loop that writes the pulses itself calls that after its
  // write.
  void computePulses();
  void writePulses();
  void prepareNextFrame();
  // The force a start from a stop begins at (fly: its idle force; 1 g unless set): a stop
  // (stopAll) and loadSlots leave every thesis curve's lookup there (placeCursors), so the
  // first frame of a start walks a few EEPROM bytes, not from a checkpoint, in its computation.
  void setStartForceDg(uint16_t force_dg);

  // Motor `index` flies the model of slot `slot` from now on (slot == index: its own again,
  // whatever it holds). Only while no motor runs; false (nothing changed) then, for an index or
  // slot outside 0..3, or when another slot is not armable.
  bool setModelSource(uint8_t index, uint8_t slot);
  // The heaviest force motor `index`'s model makes, in decigrams (v1: the lighter of its curves'
  // heaviest gram; v2: its last knot); 0 when it is not armable.
  uint16_t maxForceDg(uint8_t index) const;
  // The v2 bus filter's constant follows the frame rate (its time constant stays the same),
  // and so do the shaping filters' gains.
  void setFrameRate(uint16_t frame_hz);

  // Equal dynamics (issue 26; thrustcal/dyn_shaper.hpp): every motor whose model's slot holds
  // dynamics gets its command shaped so that its force follows `reference` (slowest: the
  // slowest of those motors at each force). Motors without dynamics fly their force as
  // commanded. Each filter restarts at its motor's present command. kNoDynamics / kBadReference:
  // nothing changed.
  enum class Shaping : uint8_t { kOn, kNoDynamics, kBadReference };
  Shaping setShaping(const tc::ShaperReference& reference);
  void clearShaping();  // every force flown as commanded again
  bool isShaping() const { return shaping_; }
  const tc::ShaperReference& shapingReference() const { return reference_; }
  uint8_t shapedMotors() const;  // motors whose command is shaped (0 when off)

  const Motor& motor(uint8_t index) const { return motors_[index]; }
  // Motor `index` can fly: the slot whose model it flies holds a valid record.
  bool isArmable(uint8_t index) const { return motors_[motors_[index].source].isArmable(); }
  uint8_t armableCount() const;  // calibrated slots
  bool isRunning() const;  // any motor commanded above 0
  const tc::BoardSettings& boardSettings() const { return board_settings_; }
  tc::BoardSettings& boardSettings() { return board_settings_; }
  const BatteryInput& battery() const { return battery_; }
  uint16_t batteryMv() const { return battery_.medianMv(); }
  // v2 motors: the voltage filter and the bench-sag filter.
  const tc::BusVoltageFilter& busFilter() const { return v2_.bus; }
  const tc::BusSagFilter& sagFilter() const { return v2_.sag; }
  uint8_t v2Motors() const { return v2_.count; }

 private:
  void loadSlot(uint8_t index, SlotReport report);
  void assignLanes();
  void flyV2Motors();
  void flyMotor(Motor& m);
  void placeCursors(uint16_t force_dg);  // every thesis motor's curves walked to force_dg now
  void shapeCommands();
  bool configureShaping();

  Motor motors_[kMotors];
  tc::BoardSettings board_settings_;  // the divider (EEPROM)
  BatteryInput battery_;
  tc::V2Frame v2_;  // the motors flying v2: bus filter, sag, their lanes
  uint16_t frame_hz_ = 400;  // the ESC frame rate the filters run at (setFrameRate)
  uint16_t start_dg_ = 10;   // where a start from a stop begins (setStartForceDg)
  bool shaping_ = false;
  tc::ShaperReference reference_;
  tc::ShaperReferenceTable reference_table_;
  uint16_t shaping_max_dg_[kMotors] = {};  // each motor's largest force (configureShaping)
};

}  // namespace fw

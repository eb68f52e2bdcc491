// What every image that flies the force API (fw::ForceActuators) says about its motors: the
// start-up line of each slot, why a motor is not armed, a motor's status line. read_run and fly
// print the same words, so a user reads one manual (docs/read_run.md).
#pragma once
#include <stdint.h>

#include "force_actuators.hpp"

namespace fw {

// "motor N"
void sayMotor(uint8_t index);
// Why a motor is not armed: "not calibrated: <status>" (a v2 slot: both copies' reasons).
void sayRecordStatus(const Motor& m);
// The start-up line of one slot (a ForceActuators::SlotReport): "motor N: ok, <summary>" or
// why it is refused. `v2`/`v1` are the decoded record (whichever the slot held).
void slotLoaded(uint8_t index, const Motor& m, const tc::ModelV2& v2, const tc::MotorCalibration& v1);
// "calibrated motors: K of 4", and a warning when none is.
void calibratedCount(uint8_t calibrated);
// Start-up (and after a divider change): the board's divider first (counts -> volts, and the
// voltages a record may hold), then the four slots, each with its line, and the count. Returns
// the number of calibrated motors.
uint8_t loadAndReport(ForceActuators& motors);
// "<prefix>motor N<middle><why it is not calibrated><suffix>" and the line end.
void motorLine(const char* prefix, uint8_t index, const Motor& m, const char* middle,
               const char* suffix);
// A pulse's tc::ForcePwmFlag bits in words, comma separated; "none" when clear.
void sayFlags(uint8_t flags);
// `status`'s line of one motor: force, pulse, battery, flags; a v2 motor's headroom.
void motorStatus(const ForceActuators& motors, uint8_t index);

}  // namespace fw

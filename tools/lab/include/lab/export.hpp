// `thrustcal lab export`: a fitted lab model as the firmware's model v2 record, written into an
// EEPROM image (Intel HEX) that read_run flies.
//
// read_run's v2 runs force = curve((pwm - start) * V_bus) with the bus voltage the battery
// monitor reads under load, plus the bench sag table for command steps. So a lab model made of
// `curve`, `deadband`, `voltage` and `sag` maps onto it: the lab curve is sampled along a PWM
// sweep at the data's highest resting voltage (no other load), each point's drive is
// (pwm - start) * the voltage the motor sees there, and tc::modelV2FromCurve places the knots.
// Every other effect has no counterpart in the record and is refused by name, with the reason.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lab/dataset.hpp"
#include "lab/model.hpp"
#include "hal/board.hpp"
#include "thrustcal/record_v2.hpp"

namespace lab {

using hal::kEepromBytes;  // the board table (hal/board.hpp)
constexpr uint8_t kEepromSlots = static_cast<uint8_t>(kEepromBytes / tc::kRecordBytes);

// Throws std::invalid_argument naming the first effect of `spec` the firmware cannot run and
// why. `motor_selected`: the data were cut to one motor (--motor), so `motor` is harmless.
void checkExportable(const ModelSpec& spec, bool motor_selected);

// Keeps the rows of motor `motor_id` (throws std::invalid_argument if there is no motor column
// or no such motor).
Dataset selectMotor(const Dataset& data, long motor_id);

struct ExportResult {
  FitResult fit;             // the lab fit
  tc::ModelV2 model;         // what was written (finalized)
  tc::RecordV2Write write;   // slot copy, sequence, bytes changed
  double start_us = 0;       // the lab model's start threshold
  double rest_v = 0;         // voltage the curve was sampled at (resting reading)
  double gamma = 1;          // the lab model's voltage exponent (the firmware's is 1)
  // The record flown (tc::forceForPwmDg) at each row's PWM and motor voltage:
  std::vector<double> v2_force_g;
  double v2_rmse_g = 0;      // against the measured force
  double v2_max_g = 0;
  double v2_vs_lab_rmse_g = 0;  // against the lab model's prediction
  double v2_vs_lab_max_g = 0;
  std::vector<std::string> notes;
};

// The limits a record must meet (core's; see export.cpp), in the lab's units.
struct RecordLimitsForExport {
  double start_min_us = 800, start_max_us = 1800;  // ESC start threshold
  double rest_min_v = 6.0, rest_max_v = 17.5;      // resting pack voltage
  double force_min_g = 13.2, force_max_g = 6553.5; // largest force of the curve
  double pwm_min_us = 1000, pwm_max_us = 2000;     // ESC pulse range of the data
  double max_sag_pct = 100;                        // battery sag, percent of the resting voltage
  const char* source = "";                         // where the values come from
};
RecordLimitsForExport recordLimits();
constexpr std::size_t kMinExportPwmLevels = 8;
constexpr double kDefaultMaxErrorPct = 3.0;

// Data a record should not be made from: PWMs outside the ESC range, too few rows or PWMs.
// Throws std::invalid_argument saying which limit failed, the value, and what to do.
void checkExportData(const Dataset& data);

// Fits `spec` on `data` (one motor), maps it onto a ModelV2 and writes it into `slot` of
// `eeprom` (kEepromBytes) as a power-fail-safe next-sequence write; other slots untouched.
// Refuses (std::invalid_argument naming the failing limit, its value and what to do) an effect
// the firmware cannot run, data that cannot make a right record (see checkExportData, force
// falling as the drive rises), a fit whose error on its own data, or whose record flown at the
// data's PWMs and voltages, misses the measured force by more than `max_error_pct` of the
// largest force (RMS), and a record outside core's limits;
// std::runtime_error when the write did not verify. `eeprom` is untouched on any failure.
ExportResult exportModel(const Dataset& data, const ModelSpec& spec, uint8_t slot,
                         std::vector<uint8_t>& eeprom, double max_error_pct = kDefaultMaxErrorPct);

}  // namespace lab

// `thrustcal lab export FILES... --to ardupilot|px4|betaflight -o FILE`: fit the autopilot's own
// thrust model (lab/autopilot.hpp) to thrust-stand measurements, compare it with the same model
// at its defaults and with thrustcal's per-motor model v2 (lab/export.hpp), and write the
// parameter file the autopilot's ground station loads.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "lab/autopilot.hpp"
#include "lab/dataset.hpp"

namespace CLI {
class App;
}

namespace lab::autopilot {

struct ExportOptions {
  std::string to;             // ardupilot | px4 | betaflight ("" = not an autopilot export)
  std::string output;         // the parameter file
  std::string plot;           // plot base name: PLOT.png, PLOT.svg, PLOT.tsv, PLOT.gp ("" = none)
  double auw_g = 0;           // take-off weight (g): hover thrust parameter (needs motors_given)
  int motors = 4;             // motors on the aircraft (hover thrust; PX4 output lines)
  bool motors_given = false;
  int cells = 0;              // 0: from the largest logged voltage
  std::string esc_range = "1000:2000";  // the ESC's calibrated pulse range, us
  std::string esc = "dshot";  // Betaflight: dshot | pwm
  double px4_v_charged = 4.05;          // PX4 BAT1_V_CHARGED (per cell) for MC_BAT_SCALE_EN
  std::string px4_prefix = "PWM_MAIN";  // PX4 output group of the motors (PWM_MAIN, PWM_AUX, ...)
  std::string v2_model;       // lab model for the v2 comparison ("" = curve+deadband+voltage[+sag])
  std::string command_line;   // written into the file's header
};

// The error of one model over a group of rows.
struct ErrorStats {
  std::size_t n = 0;
  double rms_g = NAN, max_g = NAN, rms_pct = NAN, max_pct = NAN;  // % of the largest force
};

struct ModelColumn {
  std::string name;
  std::vector<double> predicted_g;  // per row; NaN where the model has no prediction
  std::string unavailable;          // why there is no prediction at all ("" = there is)
};

struct RowGroup {
  std::string label;  // "all", "10.2 V", "motor 1"
  std::vector<std::size_t> rows;
};

struct MotorBest {
  std::string label;
  std::vector<std::pair<std::string, double>> params;  // the autopilot's parameters, fitted alone
  double own_rms_g = NAN;     // that motor with its own best parameters
  double common_rms_g = NAN;  // that motor with the one set written to the file
};

struct ExportReport {
  Autopilot to = Autopilot::kArduPilot;
  Dataset data;                      // the rows used (finite PWM and force)
  std::vector<Row> rows;
  std::vector<ModelColumn> models;   // fitted, [fitted other voltage choice], defaults, v2
  std::vector<RowGroup> groups;      // all, by voltage, by motor
  std::vector<std::pair<std::string, std::string>> params;  // written: name, value as written
  std::string summary;               // one line: the fitted parameters in words
  std::vector<MotorBest> per_motor;  // when the data hold several motors
  std::vector<std::string> notes;
  std::string file_text;             // the parameter file
  double largest_force_g = 0;
  double full_g = 0;                 // fitted full thrust
  int cells = 0;
};

// Fits and compares; throws std::invalid_argument for data that cannot be fitted (with what to
// log instead) or bad options.
ExportReport buildExport(const Dataset& data, const ExportOptions& options);
// The printed comparison (tables and notes).
std::string formatReport(const ExportReport& report);
// Writes PLOT.tsv, PLOT.gp and, through gnuplot, PLOT.png and PLOT.svg. Returns the images
// written; a warning goes into `warnings` when gnuplot fails (the data and script stay).
std::vector<std::string> writePlot(const ExportReport& report, const std::string& base,
                                   std::vector<std::string>& warnings);

// The hook into `thrustcal lab export`: adds --to, -o, --auw-g, --motors, --cells, --esc-range,
// --esc, --bat-v-charged, --px4-prefix, --plot, and relaxes --model/--slot/--eeprom to
// required-unless---to.
std::shared_ptr<ExportOptions> addExportOptions(CLI::App* export_command);
// Runs the autopilot export for the files; returns the exit code (0) or throws.
int runExport(const ExportOptions& options, const std::vector<std::string>& files,
              const std::vector<std::string>& maps, long motor, const std::string& model);

}  // namespace lab::autopilot

// The autopilot export, inside: one way to set an autopilot up (its parameters as written and
// the force it assumes), fitted or at its defaults, its errors on groups of rows, and the
// parameter file's text. Private to tools/lab/src: autopilot_fitted.cpp; autopilot_export.cpp
// builds the export, autopilot_output.cpp prints, plots and runs it.
#pragma once
#include <cmath>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "lab/autopilot.hpp"
#include "lab/autopilot_export.hpp"

namespace lab::autopilot {

constexpr double kTie = 1e-3;        // relative RSS within which the autopilot's default wins
constexpr double kCellMaxV = 4.35;   // the highest per-cell voltage a LiPo (HV) is charged to
constexpr int kMinRows = 10;
constexpr double kMinForceG = 1;  // a Crazyflie motor makes 12 g: the rest is the PWM span check
constexpr double kMinSpanUs = 100;

// One way to set the autopilot up: its parameters as written, and the force it assumes.
struct Fitted {
  std::string name;
  std::vector<std::pair<std::string, std::string>> file_params;
  std::vector<std::pair<std::string, double>> numeric;  // for the per-motor spread
  std::function<double(const Row&)> fraction;
  Scaled scale;
  std::vector<std::string> notes;
  std::string summary;
  double start_us = NAN;  // the pulse where the model's thrust starts
};

std::string num(double v, int decimals);

Fitted describe(const ArduPilotParams& p, const Scaled& s, const std::string& name);

Fitted describe(const Px4Params& p, const Scaled& s, const std::string& name, int motors, const std::string& prefix);

Fitted describe(const BetaflightParams& p, const Scaled& s, const std::string& name);

// The autopilot's fit; `voltage` lets it use its voltage term.
Fitted fitOne(Autopilot to, const std::vector<Row>& rows, FitSetup setup, bool voltage, const ExportOptions& o);

Fitted defaultsOf(Autopilot to, const std::vector<Row>& rows, const FitSetup& setup, const ExportOptions& o);

std::vector<double> predict(const Fitted& f, const std::vector<Row>& rows);

ErrorStats stats(const std::vector<Row>& rows, const std::vector<double>& pred, const std::vector<std::size_t>& which,
                 double largest);

double rmsOn(const std::vector<Row>& rows, const std::vector<double>& pred, const std::vector<std::size_t>& which);

// Groups of rows by battery voltage: clusters split at gaps of more than 0.25 V when there are
// 2..8 of them (runs at set voltages), else three equal parts (a discharging battery).
std::vector<RowGroup> voltageGroups(const std::vector<Row>& rows);

std::pair<double, double> parseRange(const std::string& text);

// The data must show the curve: enough rows, enough force, over enough PWM.
void checkFittable(const std::vector<Row>& rows, const std::string& autopilot);

std::string fileText(Autopilot to, const ExportReport& r, const std::string& command, const std::string& summary,
                     const ErrorStats& fitted, const ErrorStats& defaults);

}  // namespace lab::autopilot

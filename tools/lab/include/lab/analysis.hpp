// Where the model fails and why: residual analysis (diagnose), the error ladder, hold-out
// validation, and checks of the data a fit should not be asked to explain.
#pragma once
#include <string>
#include <vector>

#include "lab/dataset.hpp"
#include "lab/model.hpp"

namespace lab {

// What a logged variable is to the force: a condition that can change it (voltage,
// temperature, pressure, time, motor, direction, anything the user logged), or a response of
// the motor that follows from the drive (current, speed, torque, power, vibration, another
// force reading), or a copy of the drive itself (a second PWM column, a throttle percentage).
enum class Role { kCause, kResponse, kDriveCopy };
Role roleOf(const std::string& name);

struct Suspect {
  std::string variable;
  Role role = Role::kCause;
  // Fraction of the residual variance this variable explains (0..1), penalised for its degrees
  // of freedom like BIC: 1 - (RSS_with / RSS_without) * n^(q/n).
  double score = 0;
  double p_value = 1;  // F-test against "the residual does not depend on it"
  bool significant = false;
  bool categorical = false;
  bool tested = false;               // refitted (responses, drive copies and collinear time are not)
  std::vector<std::string> effects;  // effects (or a mul: template) to add; never one in the model
  std::string advice;                // plain words
};

// Every candidate variable scored against the residual, best first. Only causes are ranked as
// suspects (p below 0.001 divided by the number of variables); responses and copies of the
// drive are listed, not refitted. Time that moves with the drive (a ramp) is not tested for
// drift. On more than 20,000 rows the refits run on evenly spaced rows.
std::vector<Suspect> rankVariables(const Dataset& data, const FitResult& fit, const ModelSpec& spec);

enum class Holdout { kNone, kRuns, kVoltage };
Holdout parseHoldout(const std::string& text);  // none|runs|voltage; throws std::invalid_argument

// RMSE (g) of predictions on held-out groups (each run, or each voltage level, fitted on the
// rest). Throws std::invalid_argument when there are fewer than two groups (nothing to hold out).
double holdoutRmse(const Dataset& data, const ModelSpec& spec, Holdout kind, int* groups = nullptr);

struct Diagnosis {
  FitResult fit;
  std::vector<Suspect> variables;  // all, best first
  double holdout_rmse_g;
  int holdout_groups = 0;
};
Diagnosis diagnose(const Dataset& data, const ModelSpec& spec, Holdout holdout);

struct LadderStep {
  std::string added;  // the effect(s) this step added ("" for the start)
  ModelSpec spec;
  FitResult fit;
  std::vector<Suspect> variables;
  double holdout_rmse_g;
  double delta_bic = 0;  // against the previous step
  double delta_aic = 0;
  // The information criterion (BIC) fell by more than 2 and no parameter of the added effect
  // sits at a bound of its range (an effect pinned at "off" or at a limit earns nothing).
  bool earns = true;
  std::vector<std::string> at_bound;  // "r_sag_ohm at 0" for the added effect's parameters
  std::string verdict;                // the verdict in words
};
std::vector<LadderStep> ladder(const Dataset& data, const ModelSpec& base,
                               const std::vector<std::string>& adds, Holdout holdout);

// Thrust that falls while the drive rises (an ESC or current limit at the top of a ramp): per
// run, the force binned by PWM drops by more than 3 % of its peak above the peak's PWM and stays
// down. A monotone curve cannot follow it; fit below it (--where 'pwm_us < PEAK').
struct ForceCollapse {
  std::string run;
  double peak_pwm_us = 0, peak_force_g = 0;  // where it starts
  double top_pwm_us = 0, top_force_g = 0;    // the highest PWM bin
};
std::vector<ForceCollapse> findForceCollapse(const Dataset& data);
std::string describe(const ForceCollapse& c);

}  // namespace lab

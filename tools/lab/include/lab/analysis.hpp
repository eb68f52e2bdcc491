// Where the model fails and why: residual analysis (diagnose), the error ladder, hold-out
// validation.
#pragma once
#include <string>
#include <vector>

#include "lab/dataset.hpp"
#include "lab/model.hpp"

namespace lab {

struct Suspect {
  std::string variable;
  // Fraction of the residual variance this variable explains (0..1), penalised for its degrees
  // of freedom like BIC: 1 - (RSS_with / RSS_without) * n^(q/n).
  double score = 0;
  double p_value = 1;  // F-test against "the residual does not depend on it"
  bool significant = false;
  bool categorical = false;
  // The motor's response (rpm): it tracks whatever the drive misses, so it is scored but never
  // ranked as a suspect.
  bool outcome = false;
  std::vector<std::string> effects;  // catalogue effects (or a mul: template) that would explain it
  std::string advice;                // plain words
};

// Every candidate variable scored against the residual, best first. Only `significant` ones
// count as suspects (p below 0.001 divided by the number of variables).
// True for the motor's responses (rpm, speed, torque, power, another thrust/force reading).
bool isOutcome(const std::string& name);

std::vector<Suspect> rankVariables(const Dataset& data, const FitResult& fit, const ModelSpec& spec);

enum class Holdout { kNone, kRuns, kVoltage };
Holdout parseHoldout(const std::string& text);  // none|runs|voltage; throws std::invalid_argument

// RMSE (g) of predictions on held-out groups (each run, or each voltage level, fitted on the
// rest). NaN when there are fewer than two groups.
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
  bool earns = true;  // the information criterion (BIC) fell by more than 2
};
std::vector<LadderStep> ladder(const Dataset& data, const ModelSpec& base,
                               const std::vector<std::string>& adds, Holdout holdout);

}  // namespace lab

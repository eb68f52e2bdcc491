// Where the model fails and why: residual analysis (diagnose), the error ladder, hold-out
// validation, and checks of the data a fit should not be asked to explain.
#pragma once
#include <limits>
#include <string>
#include <vector>

#include "lab/dataset.hpp"
#include "lab/evidence.hpp"
#include "lab/model.hpp"
#include "lab/noise.hpp"
#include "lab/steps.hpp"

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

// Parameters of `effect` that the fit left at a bound, in words ("gamma at its bound 0").
std::vector<std::string> boundsOf(const FitResult& fit, const std::string& effect);

enum class Holdout { kNone, kRuns, kVoltage };
Holdout parseHoldout(const std::string& text);  // none|runs|voltage; throws std::invalid_argument

// RMSE (g) of predictions on held-out groups (each run, or each voltage level, fitted on the
// rest). Throws std::invalid_argument when there are fewer than two groups (nothing to hold out).
double holdoutRmse(const Dataset& data, const ModelSpec& spec, Holdout kind, int* groups = nullptr);

// Each finding in the responses scored as a suspect would be: the effects the registry says it
// suggests (not in the model), refitted, best first; `advice` and `significant` filled in.
void scoreEvidence(const Dataset& data, const FitResult& fit, const ModelSpec& spec, std::vector<Evidence>& evidence,
                   std::size_t tested);

// Where along the drive the residual concentrates: a PWM interval at one voltage level (run
// means rounded to 0.25 V) or at every level, holding a large share of the residual's sum of
// squares above the noise floor (of all of it when the noise is unknown) in few rows.
struct Region {
  double pwm_lo_us = 0, pwm_hi_us = 0;
  double vbat_v = std::numeric_limits<double>::quiet_NaN();  // NaN: every voltage level
  double share = 0;       // of the residual above the noise
  double rows_share = 0;  // of the rows
  double rmse_g = 0;      // in the region
  std::string text;       // "84 % of the residual above the noise is above 1670 us at 10.0 V (12 % of the rows)"
};
// Up to three regions, the strongest first; none when the residual is at the noise floor.
std::vector<Region> residualRegions(const Dataset& data, const FitResult& fit, const NoiseEstimate& noise);

// The fit against the noise floor: at it (RMSE within the noise's 95 % upper bound, and where
// the log repeats set points no significant lack of fit), above it with suspects (a logged
// variable or a finding in the responses explains part of it), or above it with nothing logged
// to explain it.
enum class Verdict { kAtNoiseFloor, kSuspects, kUnexplained };
// At the floor: RMSE within the noise's 95 % upper bound and, where the log repeats set points,
// no significant lack of fit (`lof`, when given, gets the test).
bool atNoiseFloor(const NoiseEstimate& noise, const FitResult& fit, LackOfFit* lof = nullptr);
const char* verdictName(Verdict v);  // at_noise_floor, suspects, unexplained

// What the diagnosis advises next: rows to drop (they do not measure the force), else the
// effect that explains most of the residual (a suspect's or a finding's); both empty: nothing.
struct Next {
  std::string where;
  std::string add;
  std::string why;
  double score = 0;
  // every effect a suspect or a finding names, significant ones first, each by score: what a
  // walk tries, in order, when `add` does not earn its parameters
  std::vector<std::string> candidates;
};

// A fit judged against the data's noise floor: the findings in the responses (scored), where
// the residual above the noise is, the verdict and the advice to follow.
struct Assessment {
  NoiseEstimate noise;
  LackOfFit lack_of_fit;               // the fit against the pure error (set points only)
  std::vector<MotorDynamics> dynamics;  // what a fitted `lag` says of each motor (step logs)
  std::vector<Evidence> evidence;  // findings in the responses, scored
  std::vector<Region> regions;     // where the residual above the noise is (none at the floor)
  Verdict verdict = Verdict::kUnexplained;
  double unexplained_g = 0;        // sqrt(RMSE^2 - noise^2): the error above the noise floor
  std::string verdict_text;        // the verdict in words, with where to look
  Next next;
};
// `variables`: the fit's ranked variables (rankVariables); `noise`: already estimated on these
// data, else estimated here.
Assessment assess(const Dataset& data, const ModelSpec& spec, const FitResult& fit,
                  const std::vector<Suspect>& variables, const NoiseEstimate* noise = nullptr);

struct Diagnosis : Assessment {
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
  bool at_noise_floor = false;        // RMSE within the noise floor's 95 % upper bound (and no lack of fit)
  Assessment assessment;              // the last step's (the others' noise only)
};
std::vector<LadderStep> ladder(const Dataset& data, const ModelSpec& base,
                               const std::vector<std::string>& adds, Holdout holdout);
// The ladder's next step: `prev`'s model plus `add`, fitted from prev's optimum (never worse),
// judged by BIC and the added parameters' bounds; not ranked, not assessed.
LadderStep addStep(const Dataset& data, const LadderStep& prev, const std::string& add, Holdout holdout);

// Following the diagnosis's advice to the end: diagnose; drop the rows it says do not measure
// the force, or add the effect it advises when that earns its parameters; again, until the fit
// is at the noise floor, nothing is advised, or the advice does not earn.
struct WalkStep {
  std::string model;       // the model diagnosed
  std::size_t rows = 0;    // the rows it was diagnosed on
  double rmse_g = 0;
  NoiseEstimate noise;
  Verdict verdict = Verdict::kUnexplained;
  std::string verdict_text;
  Next advice;             // what the diagnosis advised
  std::string outcome;     // what following it gave
};
struct Walk {
  std::vector<WalkStep> steps;
  std::string where;               // the rows kept (--where), "" for all
  std::vector<std::string> adds;   // the effects added, in order
  Dataset data;                    // the rows kept
  std::vector<LadderStep> ladder;  // start to the end model on the rows kept (the last assessed)
  std::string stop;                // why it stopped
};
// `holdout`: for the ladder it walked (the walk itself judges by BIC on every row).
Walk walk(const Dataset& data, const ModelSpec& start, int max_adds = 8, Holdout holdout = Holdout::kNone);

// Thrust that falls while the drive rises (a current limit, a saturated ESC or a stall at the top
// of a ramp): per run, the force binned by PWM drops by more than 3 % of its peak above the
// peak's PWM and stays down. A curve that only rises cannot follow it: model the limit, or fit
// below it (--where 'pwm_us < PEAK'); a record cannot hold it (export refuses).
struct ForceCollapse {
  std::string run;
  double peak_pwm_us = 0, peak_force_g = 0;  // where it starts
  double top_pwm_us = 0, top_force_g = 0;    // the highest PWM bin
};
std::vector<ForceCollapse> findForceCollapse(const Dataset& data);
std::string describe(const ForceCollapse& c);

}  // namespace lab

// The lab's command line, inside: the options every fitting command shares, loading the data,
// and the JSON and text every command prints the same way. Private to tools/lab/src: cli.cpp
// registers the commands (export, effects, generate), cli_fit.cpp runs diagnose, ladder, walk.
#pragma once
#include <CLI/CLI.hpp>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "lab/analysis.hpp"
#include "lab/dataset.hpp"
#include "lab/report.hpp"

namespace lab::cli {

using nlohmann::json;

struct Common {
  std::vector<std::string> files;
  std::vector<std::string> maps;
  std::string model;
  bool json_out = false;
  std::string report_dir;
  std::string holdout = "none";
  bool no_motor_split = false;
  std::string where;
  std::vector<std::string> fixes;  // --fix NAME=VALUE
};

// The model SPEC with the --fix values held.
ModelSpec specOf(const Common& c);

void addCommon(CLI::App* cmd, Common& c);

// Rows selected with --where (the count kept and dropped goes to the notes) and warnings about
// data a fit should not be asked to explain (force falling as the drive rises; `diagnose` reports
// it as evidence instead).
void selectAndCheck(Dataset& d, const std::string& where, std::vector<std::string>& warnings,
                    bool collapse_warnings = true);

Dataset load(const Common& c, std::vector<std::string>& warnings, bool collapse_warnings = true);

json num(double v);  // null when not finite

json paramsJson(const FitResult& f);

json suspectsJson(const std::vector<Suspect>& vars, bool significant);

// The variables that were not refitted, by reason: responses of the motor, copies of the drive,
// causes that could not be tested here (time in a ramp).
void addUntestedJson(json& j, const std::vector<Suspect>& vars);

void printUntested(const std::vector<Suspect>& vars);

void printNotesAndWarnings(const Dataset& d, const std::vector<std::string>& warnings);

std::string fmtSigma(const Param& p);

void printFit(const FitResult& f, const NoiseEstimate* noise = nullptr);

std::vector<std::string> reportNotes(const Dataset& d, const std::vector<std::string>& warnings);

void printReport(const ReportFiles& rep);

std::string commandLine(const std::string& sub, const Common& c, const std::vector<std::string>& adds);

// The noise floor in words: its value, the estimator and what it saw.
std::string floorText(const NoiseEstimate& n);

json noiseJson(const NoiseEstimate& n);

json lackOfFitJson(const LackOfFit& l);

json dynamicsJson(const std::vector<MotorDynamics>& dynamics);

// The lack-of-fit test and each motor's dynamics, a line each (when there are any).
void printAssessmentExtras(const Assessment& a);

json regionsJson(const std::vector<Region>& regions);

json evidenceJson(const std::vector<Evidence>& evidence);

// The diagnosis's fields beyond the fit: the noise floor, the verdict, where the residual is,
// the evidence and the advice to follow.
void addVerdictJson(json& j, const Assessment& d);

// Runs a command, printing an error (with its file, line and column for inputs) and returning 2
// instead of throwing.
template <typename F>
int guarded(F f) {
  try {
    return f();
  } catch (const InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
  }
  return 2;
}

// The commands that fit and judge a model (cli_fit.cpp).
void addDiagnose(CLI::App* lab);
void addLadder(CLI::App* lab);
void addWalk(CLI::App* lab);

}  // namespace lab::cli

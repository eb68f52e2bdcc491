// Step logs: the command held at set points and the force logged through each step (a bench's
// dynamics session: gather_store's `dyn`, or any stand logging with a time column), and what a
// fitted `lag` says of each motor's dynamics.
#pragma once
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "lab/dataset.hpp"
#include "lab/model.hpp"

namespace lab {

// Rows a block of consecutive samples of a run at one PWM needs before it counts as a set point.
constexpr std::size_t kMinSetpointRows = 12;

// The blocks of consecutive rows of each run (in logging order) at one PWM with at least
// `min_rows` rows, in the order they end.
std::vector<std::vector<std::size_t>> setpointBlocks(const Dataset& data, std::size_t min_rows = kMinSetpointRows);

// A step log: t_s logged on every row and at least half the rows in set points.
bool isStepLog(const Dataset& data);

// One motor's time constants from a fitted `lag` on a step log, and what they say.
struct MotorDynamics {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::string motor;  // "" with one motor, else its id
  double tau_up_s = kNaN, tau_up_sigma_s = kNaN;
  double tau_down_s = kNaN, tau_down_sigma_s = kNaN;
  // +1: spin-down slower than spin-up (beyond 2 sigma and 5 %), -1: faster, 0: alike
  int asymmetry = 0;
  std::string text;  // in words
};
// Empty when the fit has no up and down time constants.
std::vector<MotorDynamics> dynamicsOf(const FitResult& fit);

}  // namespace lab

// Evidence from the motor's responses: current, speed and power are not causes of the force
// (they follow the drive), but their shapes name causes. A current that stops rising at the same
// value in every run is a current limit; an rpm that stops rising is a saturated ESC; a force
// reading that stops while the rotor still speeds up is a clipped load cell; a force that falls
// while the drive rises is a limit, a stall or the measurement. Each finding says the physical
// cause in words; the effects it suggests come from the registry (EffectDef::suggests).
#pragma once
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lab/dataset.hpp"

namespace lab {

// The rows of each run, in logging order.
std::vector<std::vector<std::size_t>> rowsOfRuns(const Dataset& data);

// One run's column binned by PWM: each set point of a step sweep (up to 200 of them), else 40
// equal bins of a ramp; (bin PWM, median of the bin), in PWM order. Rows where y is not finite
// are left out.
std::vector<std::pair<double, double>> binnedMedians(const std::vector<double>& pwm, const std::vector<double>& y,
                                                     const std::vector<std::size_t>& rows);

// A response that stops rising while the drive rises: in a run, the set points at the top of the
// drive whose values stay within 0.5 % of the run's largest (at least three, after a rise);
// runs whose levels agree within 1 % share one ceiling, the one most runs reach.
struct Plateau {
  std::string column;
  double level = 0;                 // the ceiling (median of the runs' levels)
  std::vector<int> runs;            // runs that stop at it
  std::vector<double> from_pwm_us;  // where each of them reaches it
  std::size_t set_points = 0;       // set points at the ceiling, all runs
};
std::optional<Plateau> findPlateau(const Dataset& data, const std::string& column);

// The runs of `data` whose largest value of `column` is within 1 % of `level` (they reach that
// ceiling; a run that goes beyond it is not held by it).
std::vector<bool> runsAtCeiling(const Dataset& data, const std::string& column, double level);

struct Evidence {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  // current_plateau, esc_saturated, rpm_plateau, power_plateau, force_clipped, force_plateau,
  // force_falls (a limit), force_falls_at_limit (the current's ceiling explains it: the same
  // finding), motor_stalls, force_falls_rotor_rises (the measurement, not the motor)
  std::string kind;
  std::string column;                 // the response it was found in
  double level = kNaN;                // the ceiling, in the column's unit
  double from_pwm_us = kNaN;          // the lowest PWM where it starts
  std::vector<std::string> runs;      // run labels
  std::string cause;                  // the physical cause, in words
  std::string text;                   // the finding and its cause, one paragraph
  std::string where;                  // rows that do not measure the force (--where keeps the rest)
  // filled by the diagnosis: the effects the registry says it suggests, best first, with the
  // score of the best (as for a suspect) and whether it is significant
  std::vector<std::string> effects;
  double score = 0;
  double p_value = 1;
  bool significant = false;
  std::string advice;  // the registry's words for the best effect ("" when none applies)
};

// Every finding in the data's responses (current_a, rpm, power_w and their RCbenchmark names)
// and in the force's shape. Empty when the responses are not logged and the force rises.
std::vector<Evidence> gatherEvidence(const Dataset& data);

}  // namespace lab

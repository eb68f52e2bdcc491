// Step-response figures of a sampled response, as MATLAB's stepinfo and python-control's
// step_info define them (the swap experiment, `thrustcal sim swap`, computes them from the rig's
// true attitude):
//   rise        from 10 % to 90 % of the way from y0 to the final value (first crossings);
//   overshoot   how far the peak goes past the final value, in % of (final - y0);
//   settling    when |y - final| last enters a band of 2 % of |final - y0| and stays;
//   sse         |target - final|: what the loop leaves of the command;
//   itae        the integral of t |target - y| dt over the window, t from the step (deg s^2
//               for angles in degrees).
// The final value is the mean over the window's last `final_window_s` (noise averages out).
// Crossings are interpolated linearly between samples. A response that never reaches 90 % has
// no rise time, one still outside the band at the end no settling time: NaN, never a guess.
#pragma once
#include <vector>

namespace sim {

struct StepSpec {
  double y0 = 0;      // the value before the step (e.g. its mean over the last 0.1 s)
  double target = 0;  // the command after the step
  double final_window_s = 0.25;
  double rise_low = 0.10, rise_high = 0.90;
  double settle_band = 0.02;  // of |final - y0|
};

struct StepMetrics {
  double rise_s = 0;
  double overshoot_pct = 0;  // 0 when the response never passes its final value
  double settling_s = 0;
  double sse = 0;   // in y's unit
  double itae = 0;  // y's unit times s^2
  double final_value = 0;
  double peak = 0;  // the extreme in the step's direction
};

// `t_s` from the step (t = 0 at the step, increasing), `y` the response, same length, at least
// three samples after t = 0. Throws std::invalid_argument for empty, unequal or unordered
// series, or a response that does not move (final == y0).
StepMetrics stepMetrics(const std::vector<double>& t_s, const std::vector<double>& y, const StepSpec& spec);

// The mean of each channel over the rows with t_s in [from_s, to_s] (rows are per sample,
// columns per channel), then max - min over the channels: the spread of the four pulses at hover.
// Throws std::invalid_argument when no row falls in the window.
double meanSpread(const std::vector<double>& t_s, const std::vector<std::vector<double>>& rows, double from_s,
                  double to_s);

}  // namespace sim

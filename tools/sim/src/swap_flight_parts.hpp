// What fly's flights and a peer's share in the swap experiment (sim/src/swap_flight.cpp): the
// rig with the run's motors, the log's window around the step, its figures, its time series.
#pragma once
#include <chrono>
#include <string>
#include <vector>

#include "sim/airframe.hpp"
#include "sim/swap.hpp"

namespace sim::swap {

// The rig of a run: the stock motors varied by their seeds, the part in slot 1, the IMU unit,
// the log period (the gimbal in the plus layout; a peer changes layout, pins, spin and mount).
AirframeOptions rigOptions(const SwapOptions& o, const RunSpec& r);
// The rows of the rig's log from `settle_s` before the step to the window's end.
std::vector<AirSample> windowOf(const std::vector<AirSample>& log, double t_step, double settle_s,
                                double window_s);
// The step's figures (the window's rows, t from the step), y0 and the hover pulse spread.
void measure(RunResult& res, const std::vector<AirSample>& rows, double t_step, const SwapOptions& o);
// The flight from the first step's level flight on, t from the first step; sp_deg while a step
// (`t_steps`, each held `window_s`) is on, 0 otherwise.
void writeSeries(const std::string& path, const std::vector<AirSample>& rows, const std::vector<double>& t_steps,
                 double window_s, const RunSpec& r, double sp_deg);
// After the last window: each step's figures from the log (the first with `settle_s` of level
// flight before it, the others with their return to level), their means, the time series written
// to `csv_path` ("" = none), the simulated and wall times.
void finishRun(RunResult& res, AirframeRig& rig, const std::vector<double>& t_steps, double settle_s,
               const SwapOptions& o, const std::string& csv_path, std::chrono::steady_clock::time_point wall0);

}  // namespace sim::swap

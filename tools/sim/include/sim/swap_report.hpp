// What `thrustcal sim swap` shows of a SwapResult (sim/swap.hpp): the table, stock and each
// swapped part side by side per rig, axis, gains and mode (means over the IMU units); the
// targets; what calibration cannot equalise; and the plots drawn with gnuplot.
#pragma once
#include <string>
#include <vector>

#include "sim/swap.hpp"

namespace sim::swap {

// One table of figures: a rig's axis with one set of gains, a row per mode and part (means over
// the IMU units), a part's change against stock in the same mode in brackets. The bench's swap
// section and docs/fly.md show these cells; formatTable prints them aligned.
struct FigureTable {
  AirRig rig = AirRig::kGimbal;
  std::string axis;
  Gains gains = Gains::kPd;
  std::string title;  // "seesaw roll, PD gains (800 0 146 mN m), 10-degree step, mean of 3 IMU unit(s)"
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};
std::vector<FigureTable> figureTables(const SwapResult& result);

std::string formatTable(const SwapResult& result);
std::string formatTargets(const SwapResult& result);
std::string formatDynamics(const SwapResult& result);

// Into `dir`: steps_MODE.png (the step responses of stock and each part overlaid, one panel per
// rig and axis, PD gains, the first IMU unit) and bars_MODE.png (rise, overshoot, ITAE and the
// hover pulse spread per part, PD gains, means over the IMU units), with their data (.tsv) and
// script (swap_plots.gp). Returns the images; a gnuplot failure is a warning (data and script stay).
std::vector<std::string> writePlots(const SwapResult& result, const std::string& dir,
                                    std::vector<std::string>& warnings);

}  // namespace sim::swap

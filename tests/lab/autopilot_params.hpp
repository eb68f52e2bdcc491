// Autopilot parameter sets the autopilot tests share.
#pragma once
#include "lab/autopilot.hpp"

namespace {

// ArduPilot as most copters run it: defaults, 1000-2000 us, compensation for 3S (4.2 / 3.3 V per cell).
lab::autopilot::ArduPilotParams ardu3s() {
  lab::autopilot::ArduPilotParams p;
  p.bat_volt_max_v = 12.6;
  p.bat_volt_min_v = 9.9;
  return p;
}

}  // namespace

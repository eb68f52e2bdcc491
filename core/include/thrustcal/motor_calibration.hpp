// Everything stored for one motor (thesis table 6.2): the first curve (LiPo) with its start
// voltage and sag offsets, and the optional second curve (another voltage).
#pragma once
#include <stdint.h>

#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/force_curve.hpp"

namespace tc {

struct MotorCalibration {
  ThesisCurve first;   // first.start_mv == 0: motor not calibrated
  SagTable sag;        // measured with the first curve
  ThesisCurve second;  // second.start_mv == 0: no second curve

  bool isCalibrated() const { return first.isPresent(); }
  bool hasSecondCurve() const { return second.isPresent(); }
  void clear();
};

}  // namespace tc

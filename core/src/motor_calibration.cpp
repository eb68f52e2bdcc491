#include "thrustcal/motor_calibration.hpp"

namespace tc {

void MotorCalibration::clear() {
  first.clear();
  second.clear();
  sag = SagTable();
}

}  // namespace tc

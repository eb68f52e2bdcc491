// fly's console view: every line the image prints, in one place. It only reads (the app's
// observers) and prints; deciding and flying stay in fly_app.cpp and commands.cpp. What any
// force-API image says about a slot is shared (firmware/common/slot_report.hpp).
#pragma once
#include <stdint.h>

#include "fly_app.hpp"

namespace fly {
namespace view {

void banner();
// After start-up: the IMU runs (and how it is set), or why not.
void imuStarted(const Mpu6050& imu);
void imuFault(const Mpu6050& imu);
void imuRunningAgain();
void calibrating();
void calibrationResult(const FlyApp& app);
// What `level` did: the trim taken, or why it was refused.
void levelResult(const FlyApp& app);
void armRefused(ArmRefusal why, const FlyApp& app);
void armed(const FlyApp& app);
// What the sticks' arming gesture did: armed, or why not.
void stickArm(const FlyApp& app);
// `rc`, `rcmap`, `rates`, `fmode`: the receiver's settings now.
void receiver(const FlyApp& app);
void disarmed(const FlyApp& app);
// Replies to the setting commands: what is set now.
void setpoint(const FlyApp& app);
void thrust(const FlyApp& app);
void gains(const FlyApp& app);
void mode(const FlyApp& app);
void genericSlotRefused(uint8_t slot, const fw::Motor& m);
void layout(const FlyApp& app);
void hover(const FlyApp& app);
void arduPilot(const FlyApp& app);
void crashLimit(const FlyApp& app);
// `status`: state, IMU, attitude, settings, loop timing, motors, battery, console health.
void status(const FlyApp& app, const LoopStats& loop, void (*yield)());
void streamHeader();
void streamRow(const StreamRow& row);
// The rules after the command rows of `help`, with their constants.
void helpFooter();

}  // namespace view
}  // namespace fly

// read_run's console view: every line the image prints about motors, records, the lift-off
// and its status, in one place. It only reads (the app's observers and the motor structs) and
// prints; deciding and flying stay in read_run_app.cpp, frame.cpp and commands.cpp. What any
// force-API image says about a motor's slot is shared (firmware/common/slot_report.hpp).
#pragma once
#include <stdint.h>

#include "read_run_app.hpp"

namespace rr {
namespace view {

void banner();
// "error: motor N is <why>; it stays at 1000 us - recalibrate it with gather_store"
void refuseMotor(uint8_t index, const Motor& m);
// `f G` with a motor that is not calibrated: "warning: motor N <why>; held at 1000 us"
void heldMotor(uint8_t index, const Motor& m);
// "error: liftoff needs all four motors calibrated; motor N is <why>; ..."
void liftoffNeedsAll(uint8_t index, const Motor& m);
void liftoffStarted(uint16_t force_g, uint16_t ramp_ms, uint16_t hold_ms);
void liftoffHold(const ReadRunApp& app);
void liftoffProgress(const ReadRunApp& app, uint32_t elapsed_ms, uint16_t force_g);
void liftoffDone();
void liftoffAborted();
void liftoffLinkLost();
void failsafe();
// `status`: one line per motor, the v2 bus filter, the battery and the console's health.
void status(const ReadRunApp& app, void (*yield)());
void streamHeader();
// "t_s,motor0_pwm_us..motor3_pwm_us,vbat_v"
void streamRow(const ReadRunApp& app, uint32_t now_ms);
// The console rules after the command rows of `help`, with their constants.
void helpFooter();

}  // namespace view
}  // namespace rr

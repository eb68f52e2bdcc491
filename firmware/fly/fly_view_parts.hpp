// The words and numbers fly's console view is made of, shared by fly_view.cpp and
// fly_status_view.cpp: numbers in 16 bits where they fit (printFixed16: no 32-bit division, as
// status runs beside the frames), the names of modes and layouts, an IMU fault in words.
#pragma once
#include <stdint.h>

#include "fly_app.hpp"

namespace fly {
namespace view {

void sayFixed(int32_t value, uint8_t decimals);  // value / 10^decimals
void sayCount(uint32_t value);
void sayFloat(float v, uint8_t decimals);  // rounded to `decimals`
void sayDeg(float rad);                    // in degrees, one decimal
void sayMilli(float v);                    // v * 1000, whole
void sayMs(uint32_t ms);                   // "N ms"
void sayFault(const Mpu6050& imu);         // what is wrong with the IMU, in words
const char* modeName(OutputMode mode);     // flash text
const char* layoutName(Layout layout);     // flash text
// "IMU read at P us of each F us frame, computation budget B us".
void sayFrameLayout(const FlyApp& app);
// "motor N is ...; calibrate it ..." for the first motor of the layout that cannot fly.
void sayUnflyableMotor(const FlyApp& app);

}  // namespace view
}  // namespace fly

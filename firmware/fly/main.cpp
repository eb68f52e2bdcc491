// fly image for the ATmega2560: attitude control on the calibrated actuators (issue 19).
// All logic lives in fly_app.cpp and its parts, which the host tests run against the fake HAL.
#include <avr/avr_mcu_section.h>

#include "fly_app.hpp"
#include "hal/hal.hpp"
#include "params.hpp"
#include "simavr_mcu_tag.hpp"

// simavr reads the part, clock and supply voltages from this tag (the virtual airframe).
AVR_MCU(F_CPU, "atmega2560");
AVR_MCU_VOLTAGES(5000, 5000, 5000);

namespace {
fly::FlyApp app;  // the motors, the IMU, the controller and the console live here, in .bss
}  // namespace

int main() {
  hal::Esc::init(fly::kLoopHz);  // first: the ESCs see the stop pulse from power-on, a frame per loop
  hal::Clock::init();
  hal::Uart::init(hal::kUartBaud);
  hal::Adc::init();
  hal::Twi::init(hal::kTwiFastHz);
  // The boot code (.init3) switched the watchdog off and saved why the chip reset; from here on
  // a loop that stops coming round resets it within ~64 ms (docs/safety.md).
  hal::Watchdog::start();

  app.printBanner();
  app.loadCalibration();  // the four slots, once (the force API)
  app.start();            // the frames begin: the IMU read at a fixed point of every ESC frame
  fly::Params::load(app); // the saved parameters, or the defaults (and why)
  app.startImu();         // WHO_AM_I, then its settings
  app.calibrateGyro();    // the gyro's bias at rest

  for (;;) {  // every frame: IMU -> attitude -> torque -> forces -> pulses
    app.runOnce();
    // Asleep until an interrupt brings work (the end of a frame's IMU read, a received byte),
    // through the 1 ms ticks and the read's own byte interrupts.
    hal::Clock::sleepUntil(&fly::FlyApp::hasWork);
  }
}

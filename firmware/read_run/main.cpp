// read_run image for the ATmega2560 (thesis "Read and Run", appendix H.1 main function).
// All logic lives in read_run_app.cpp, which the host tests run against the fake HAL.
#include <avr/avr_mcu_section.h>

#include "simavr_mcu_tag.hpp"
#include "hal/hal.hpp"
#include "read_run_app.hpp"

// simavr reads the part, clock and supply voltages from this tag (the virtual bench).
// simavr_mcu_tag.hpp (shared with gather_store) makes the C header's tags survive C++.
AVR_MCU(F_CPU, "atmega2560");
AVR_MCU_VOLTAGES(5000, 5000, 5000);

namespace {
rr::ReadRunApp app;  // the four motors and the console live here, in .bss
}  // namespace

int main() {
  hal::Esc::init(hal::kEscDefaultFrameHz);  // first: the ESCs see 1000 us from power-on
  hal::Clock::init();
  hal::Uart::init(hal::kUartBaud);
  hal::Adc::init();
  // The boot code (.init3) switched the watchdog off and saved why the chip reset; from here on
  // a loop that stops coming round resets it within ~64 ms (docs/safety.md).
  hal::Watchdog::start();

  app.printBanner();
  app.loadCalibration();  // H.2: the four EEPROM records, read once
  app.arm();              // 1000 us for 2 s

  for (;;) {              // H.3 every ESC frame: force command -> PWM
    app.runOnce();
    hal::Clock::sleepUntilInterrupt();  // wake on the 1 ms tick or a received byte
  }
}

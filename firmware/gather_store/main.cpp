// gather_store image for the ATmega2560 (thesis "Gather and Store", fig. 6.8, appendix G.1).
// The logic is gs::GatherStoreApp, which the host tests run against the fake HAL; fig. 6.8's
// boxes are its commands (gather_store_commands.cpp): choose motor and weigh, calibrate and
// zerolize (settings_commands.cpp), sweep (sweep_runner.cpp), "first or second?" and store
// (store_decision.cpp, gather_store_app.cpp).
#include <avr/avr_mcu_section.h>

#include "gather_store_app.hpp"
#include "hal/hal.hpp"
#include "simavr_mcu_tag.hpp"

// simavr reads the part, clock and supply voltages from this tag (the virtual bench).
// simavr_mcu_tag.hpp makes the C header's tags survive C++ (see there).
AVR_MCU(F_CPU, "atmega2560");
AVR_MCU_VOLTAGES(5000, 5000, 5000);

namespace {
gs::GatherStoreApp app;  // sweep buffers, median windows and the record buffer live in .bss
}  // namespace

int main() {
  hal::Esc::init(hal::kEscDefaultFrameHz);  // first: the ESC sees 1000 us from power-on
  hal::Clock::init();
  hal::Uart::init(hal::kUartBaud);  // hal/board.hpp (its baud error is checked there)
  hal::Adc::init();
  // The boot code (.init3) switched the watchdog off and saved why the chip reset; from here on
  // a loop that stops coming round resets it within ~64 ms (docs/safety.md).
  hal::Watchdog::start();

  app.begin();  // arm (1000 us), banner, prompt

  for (;;) {  // choose motor, weigh, calibrate, tare, sweep, store 1 / store 2, show ...
    app.poll();
    hal::Clock::sleepUntilInterrupt();  // wake on the 1 ms tick or a received byte
  }
}

// INT0..INT7 as the chip has them (ATmega2560 datasheet, "External Interrupts"): INT0-3 on
// PD0-3, INT4-7 on PE4-7; EICRA/EICRB choose low level, any edge, falling or rising edge; EIMSK
// enables; EIFR holds the edge flags (write one to clear; always 0 for a level interrupt, which
// is requested for as long as the pin stays low and the interrupt is enabled, again after each
// RETI while it lasts). Pins that are outputs trigger them as well.
//
// In place of simavr 1.6's external interrupts, whose low-level sense (the reset default)
// polls a low INT pin every cycle whether the interrupt is enabled or not: a PWM output on PE4/
// PE5 (Arduino D2/D3) held low most of the time cost a third of the run time. Here a level
// request follows the pin's edges, EIMSK and EICRx, so nothing is polled; EIFR's write-one-to-
// clear also works (simavr 1.6 stored the written value).
#pragma once
#include <array>
#include <cstdint>

struct avr_t;
struct avr_irq_t;
struct avr_extint_t;
struct avr_int_vector_t;

namespace sim {

class ExtInt {
 public:
  static constexpr int kLines = 8;
  explicit ExtInt(avr_t* avr);
  ~ExtInt();
  ExtInt(const ExtInt&) = delete;
  ExtInt& operator=(const ExtInt&) = delete;

  void afterReset() { levels_requested_ = 0; }

 private:
  struct Line {
    ExtInt* owner;
    int n;
  };
  static void onPin(avr_irq_t* irq, uint32_t value, void* param);
  static void onRunning(avr_irq_t* irq, uint32_t value, void* param);
  static void onSenseWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static void onMaskWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static void onFlagWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  uint8_t sense(int n) const;  // ISCn1:0
  avr_int_vector_t* vector(int n) const;
  void updateLevel(int n, bool pin_low);
  void updateLevel(int n);  // with the pin as it is

  avr_t* avr_;
  avr_extint_t* core_;
  std::array<avr_irq_t*, kLines> pins_{};
  std::array<Line, kLines> lines_{};
  uint8_t levels_requested_ = 0;  // lines whose pending request is a low level's
};

}  // namespace sim

// An RC receiver's outputs wired to the board's pins, as a simavr part (one struct;
// rc_receiver_init allocates its IRQs, rc_receiver_connect wires them to pins; the way simavr's
// examples/parts are written). Every edge is put on the pin by a cycle timer at its cycle (no
// work between edges) through the board's ports (Ports::setInput: the pin's simavr IRQ is
// raised with the edge's cycle), so PINx reads it and whatever listens to the pin sees the edge
// at that cycle (pin-change interrupts, sim/pin_change.hpp; INT0-7, sim/ext_int.hpp; a timer's
// input capture, sim/timers.hpp). The levels are held as the pins' external levels, so the
// firmware's pull-ups do not override them.
//
// PPM sum, one pin (receivers' "CPPM" output), 8 channels, idle high:
//
//     ___   _______   ________        _______   _______________________   ___
//        |_|       |_|        |_ ... |       |_|                       |_|
//        ^ 300 us low separator      ch8       ^ end of ch8   sync gap   ^ next frame
//        |<- ch1 ->|<-- ch2 -->|
//
//   a frame starts with a falling edge; each channel is the time from one falling edge to the
//   next (equally, from one rising edge to the next: a decoder may time either); a 300 us low
//   separator starts each channel and one more ends the last; then the line stays high to the
//   frame's end. The frame is 22.5 ms (sync gap, rising edge to rising edge, 22.5 ms minus the
//   channels' sum: 6.5 ms at 8 x 2000 us), stretched so that the gap is never below 4 ms.
//
// PWM, one pin per channel (a receiver's servo outputs), low between pulses:
//
//   ch1  _|~~~~~~|________________________________________|~~~~~~|____
//   ch2  ________|~~~~~~~|_____________________________________________
//   ch3  ________________|~~~~~|_______________________________________
//          frame start                            20 ms later
//
//   one high pulse of the channel's width per frame on each pin, one after the other: channel
//   k+1 rises in the cycle channel k falls (as receivers that demultiplex their PPM stream
//   do); a frame is 20 ms (50 Hz), stretched so that at least 2 ms pass between the last fall
//   and the next frame.
//
// Values: microseconds, 500..2500 (wider than any receiver's 900..2100, so a test can send
// out-of-range pulses), to the cycle (1/16 us). What rc_receiver_set() or rc_receiver_loss()
// asks takes effect at the next frame's start, as a receiver latches one frame at a time; a
// frame under way is finished. Before the first rc_receiver_set() and after
// rc_receiver_loss() there is no signal: no edges, the PPM line idle high, PWM lines low.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hal/mega_pins.hpp"

struct avr_t;
struct avr_irq_t;

namespace sim {

class Ports;

constexpr int kRcChannels = 8;
constexpr double kRcChannelMinUs = 500.0;
constexpr double kRcChannelMaxUs = 2500.0;
constexpr double kRcNeutralUs = 1500.0;      // a channel never set
constexpr double kPpmFrameUs = 22500.0;
constexpr double kPpmSeparatorUs = 300.0;
constexpr double kPpmMinSyncUs = 4000.0;
constexpr double kPwmFrameUs = 20000.0;
constexpr double kPwmMinGapUs = 2000.0;

enum class RcSignal { kPpm, kPwm };
const char* rcSignalName(RcSignal s);  // "ppm", "pwm"

// What the receiver puts out in one frame.
struct RcFrame {
  bool on = false;  // false: no signal
  std::array<double, kRcChannels> us{kRcNeutralUs, kRcNeutralUs, kRcNeutralUs, kRcNeutralUs,
                                     kRcNeutralUs, kRcNeutralUs, kRcNeutralUs, kRcNeutralUs};
};

struct RcPart {
  avr_t* avr = nullptr;
  avr_irq_t* irq = nullptr;  // [i] line i's level: PPM line 0, PWM channel i on line i
  RcSignal signal = RcSignal::kPpm;
  int lines = 0;             // PPM 1, PWM the channels wired (1..8)
  std::array<hal::MegaPin, kRcChannels> pins{};
  Ports* ports = nullptr;    // set by rc_receiver_connect
  RcFrame next;              // what the next frame carries
  RcFrame frame;             // the frame under way
  struct Edge {
    uint64_t cycle;
    uint8_t line;
    uint8_t level;
  };
  std::array<Edge, 2 * kRcChannels + 2> edges{};
  int edge_count = 0, edge_next = 0;
  uint64_t frame_start = 0;  // cycle this frame began
  uint64_t frame_cycles = 0;
  uint64_t frames = 0;       // frames with a signal since init
  std::array<uint8_t, kRcChannels> level{};
  RcPart() = default;
  RcPart(const RcPart&) = delete;
  RcPart& operator=(const RcPart&) = delete;
  ~RcPart();  // stops its clock and disconnects (the board must outlive it)
};

// Allocates the part's IRQs and starts its frame clock now. `lines`: 1 for PPM, the number of
// channels for PWM. Throws std::invalid_argument for a count out of range.
void rc_receiver_init(avr_t* avr, RcPart& part, RcSignal signal, int lines);
// Wires line i to pins[i] (as many pins as lines) of the board's `ports` and drives them at
// their idle level.
void rc_receiver_connect(RcPart& part, Ports& ports, const std::vector<hal::MegaPin>& pins);
// Channels 1..count (count <= 8) from the next frame on; the others keep their values.
// Throws std::invalid_argument for a value outside 500..2500 us (nothing changes then).
void rc_receiver_set(RcPart& part, const double* us, int count);
// No signal from the next frame on (until the next rc_receiver_set()).
void rc_receiver_loss(RcPart& part);
// After a board reset: the AVR's reset cancelled the cycle timer; the receiver has its own
// supply, so it goes on where it was (the pins kept their levels: Ports::afterReset).
void rc_receiver_rearm(RcPart& part);

}  // namespace sim

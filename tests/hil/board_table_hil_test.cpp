// The board table (hal/board.hpp) is the one home of the ESC pins: the firmware derives its
// compare registers from it (hal/avr/esc.cpp) and the simulator its pin wiring (sim::Board).
// This test fails when the two disagree: read_run drives four different pulses, and each must
// leave on the port bit the table names for its motor (watched here directly on simavr's pin)
// and be what the simulator reports for that motor.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <array>

#include "hal/board.hpp"
#include "hil_support.hpp"
#include "sim/console.hpp"
#include "sim/faults.hpp"
#include "sim/rigs.hpp"

extern "C" {
#include <simavr/avr_ioport.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_irq.h>
}

namespace {

// Pulse widths seen on one port bit, from its edges (simavr's pin IRQ).
struct PinWatch {
  avr_t* avr = nullptr;
  uint64_t rise_cycle = 0;
  double last_width_us = 0;
  int pulses = 0;

  static void onEdge(avr_irq_t*, uint32_t level, void* param) {
    auto* w = static_cast<PinWatch*>(param);
    if (level) {
      w->rise_cycle = w->avr->cycle;
    } else if (w->rise_cycle != 0) {
      w->last_width_us = static_cast<double>(w->avr->cycle - w->rise_cycle) * 1e6 / hal::kCpuHz;
      ++w->pulses;
    }
  }
};

TEST(BoardTable, EachMotorsPulseLeavesOnThePinTheTableNamesAndTheSimulatorMeasuresItThere) {
  HIL_REQUIRE_IMAGE("read_run");
  // given: read_run on the quad with four calibrated slots, every table pin watched directly
  std::array<plant::ActuatorParams, 4> motors;
  motors.fill(plant::presetParams("kv1100_9x4.7"));
  sim::QuadRig rig(hil::imagePath("read_run"), plant::QuadFrameParams{}, motors);
  rig.board.setEeprom(sim::calibratedTestEeprom());
  std::array<PinWatch, hal::kEscChannels> watch{};
  for (int ch = 0; ch < hal::kEscChannels; ++ch) {
    watch[ch].avr = rig.board.avr();
    avr_irq_register_notify(avr_io_getirq(rig.board.avr(), AVR_IOCTL_IOPORT_GETIRQ(hal::kEscPins[ch].port),
                                          hal::kEscPins[ch].bit),
                            &PinWatch::onEdge, &watch[ch]);
  }
  sim::Console con(rig.board, "rr> ");
  sim::bootReadRun(con);
  // when: a different force on each motor, so each pulse has its own width
  for (int ch = 0; ch < hal::kEscChannels; ++ch) con.command(fmt::format("f {} {}", ch, 60 + 60 * ch));
  rig.board.runFor(0.1);
  // then: each table pin carries its motor's pulse, the simulator's channel reads that pin, and
  // no two motors share a width (a swapped pair of pins would show here)
  for (int ch = 0; ch < hal::kEscChannels; ++ch) {
    const hal::EscPin& pin = hal::kEscPins[ch];
    SCOPED_TRACE(fmt::format("ESC {}: D{} P{}{}", ch, pin.arduino_pin, pin.port, pin.bit));
    ASSERT_GT(watch[ch].pulses, 0);
    EXPECT_GT(watch[ch].last_width_us, 1050.0);
    EXPECT_NEAR(rig.board.escPulseUs(ch), watch[ch].last_width_us, 0.3);
    if (ch > 0) {
      EXPECT_GT(watch[ch].last_width_us, watch[ch - 1].last_width_us + 5.0);
    }
  }
}

}  // namespace

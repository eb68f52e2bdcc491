// The board's ESC pulse measurement (sim/board.hpp, "ESC pins"): the high time between two
// edges of any pin, timestamped with the cycle each edge happened at.
#include "sim/board.hpp"

#include <stdexcept>

#include "sim/pin_names.hpp"
#include "sim/ports.hpp"

extern "C" {
#include <simavr/sim_avr.h>
#include <simavr/sim_irq.h>
}

namespace sim {

void Board::setEscPins(const std::array<hal::MegaPin, kEscChannels>& pins) {
  for (int i = 0; i < kEscChannels; ++i) {
    if (!ports_->pinIrq(pins[i].port, pins[i].bit))
      throw std::invalid_argument("setEscPins: " + megaPinName(pins[i]) + " is not a pin of the ATmega2560");
    for (int j = 0; j < i; ++j)
      if (pins[i].port == pins[j].port && pins[i].bit == pins[j].bit)
        throw std::invalid_argument("setEscPins: " + megaPinName(pins[i]) + " carries two ESC outputs");
  }
  bool same = true;
  for (int i = 0; i < kEscChannels; ++i) same = same && pins[i].port == esc_pins_[i].port && pins[i].bit == esc_pins_[i].bit;
  if (same) return;  // what was measured stays
  wireEscPins(false);
  esc_pins_ = pins;
  esc_.fill(EscPin{});
  wireEscPins(true);
}

void Board::wireEscPins(bool on) {
  for (int ch = 0; ch < kEscChannels; ++ch) {
    avr_irq_t* irq = ports_->pinIrq(esc_pins_[ch].port, esc_pins_[ch].bit);
    edge_params_[ch] = EdgeParam{this, ch};
    if (on) {
      esc_[ch].high = irq->value != 0;  // a pin high already: its first pulse starts at a rise
      avr_irq_register_notify(irq, &Board::onEscEdge, &edge_params_[ch]);
    } else {
      avr_irq_unregister_notify(irq, &Board::onEscEdge, &edge_params_[ch]);
    }
  }
}

void Board::onEscEdge(avr_irq_t*, uint32_t value, void* param) {
  auto* p = static_cast<EdgeParam*>(param);
  p->board->escEdge(p->channel, value != 0);
}

void Board::escEdge(int channel, bool level) {
  EscPin& pin = esc_[channel];
  if (level == pin.high) return;
  const uint64_t now = ports_->changeCycle();
  pin.high = level;
  if (level) {
    if (pin.last_rise_cycle != 0)
      pin.last_period_us = static_cast<double>(now - pin.last_rise_cycle) * 1e6 / kCpuHz;
    pin.last_rise_cycle = now;
  } else {
    pin.last_fall_cycle = now;
    if (pin.last_rise_cycle != 0) {
      pin.last_pulse_us = static_cast<double>(now - pin.last_rise_cycle) * 1e6 / kCpuHz;
      ++pin.pulses;
      for (auto& listener : pulse_listeners_)
        listener(channel, pin.last_pulse_us, cyclesToSeconds(now));
    }
  }
}

double Board::escPulseUs(int channel, double max_age_s) const {
  const EscPin& pin = esc_.at(channel);
  if (pin.pulses == 0) return 0;
  if (cyclesToSeconds(cycle() - pin.last_fall_cycle) > max_age_s) return 0;
  return pin.last_pulse_us;
}

}  // namespace sim

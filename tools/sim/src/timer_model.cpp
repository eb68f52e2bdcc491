// One ATmega2560 Timer/Counter in timer clock ticks: see sim/timer_model.hpp. The rules are the
// ATmega2560 datasheet's, 8-bit Timer/Counter0 and 2 and 16-bit Timer/Counter1/3/4/5 chapters
// ("Modes of Operation", "Compare Match Output Unit", "Timer/Counter Timing Diagrams" and the
// WGM and COM tables).
#include "sim/timer_model.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace sim {

TimerMode timerMode(bool wide, uint8_t wgm) {
  using W = Waveform;
  using T = TopSource;
  TimerMode m;
  auto fixed = [&](W w, uint16_t top) {
    m.waveform = w;
    m.top = T::kFixed;
    m.fixed_top = top;
  };
  auto variable = [&](W w, T top, bool toggles_a) {
    m.waveform = w;
    m.top = top;
    m.toggles_a = toggles_a;
  };
  if (!wide) {  // WGMn2:0 of Timer0 and Timer2
    switch (wgm & 7) {
      case 0: fixed(W::kNormal, 0xFF); break;
      case 1: fixed(W::kPhaseCorrect, 0xFF); break;
      case 2: variable(W::kCtc, T::kOcrA, false); break;
      case 3: fixed(W::kFastPwm, 0xFF); break;
      case 5: variable(W::kPhaseCorrect, T::kOcrA, true); break;
      case 7: variable(W::kFastPwm, T::kOcrA, true); break;
      default: m.reserved = true; break;  // 4, 6
    }
    return m;
  }
  switch (wgm & 15) {  // WGMn3:0 of Timer1/3/4/5
    case 0: fixed(W::kNormal, 0xFFFF); break;
    case 1: fixed(W::kPhaseCorrect, 0x00FF); break;
    case 2: fixed(W::kPhaseCorrect, 0x01FF); break;
    case 3: fixed(W::kPhaseCorrect, 0x03FF); break;
    case 4: variable(W::kCtc, T::kOcrA, false); break;
    case 5: fixed(W::kFastPwm, 0x00FF); break;
    case 6: fixed(W::kFastPwm, 0x01FF); break;
    case 7: fixed(W::kFastPwm, 0x03FF); break;
    case 8: variable(W::kPhaseFrequencyCorrect, T::kIcr, true); break;
    case 9: variable(W::kPhaseFrequencyCorrect, T::kOcrA, true); break;
    case 10: variable(W::kPhaseCorrect, T::kIcr, true); break;
    case 11: variable(W::kPhaseCorrect, T::kOcrA, true); break;
    case 12: variable(W::kCtc, T::kIcr, false); break;
    case 14: variable(W::kFastPwm, T::kIcr, true); break;
    case 15: variable(W::kFastPwm, T::kOcrA, true); break;
    default: m.reserved = true; break;  // 13
  }
  return m;
}

const char* waveformName(Waveform w) {
  switch (w) {
    case Waveform::kNormal: return "normal";
    case Waveform::kCtc: return "CTC";
    case Waveform::kFastPwm: return "fast PWM";
    case Waveform::kPhaseCorrect: return "phase-correct PWM";
    case Waveform::kPhaseFrequencyCorrect: return "phase and frequency correct PWM";
  }
  return "?";
}

TimerModel::TimerModel(bool wide, int channels)
    : wide_(wide), channels_(channels), max_(wide ? 0xFFFF : 0xFF) {
  reset();
}

void TimerModel::reset() {
  wgm_ = 0;
  mode_ = timerMode(wide_, 0);
  com_.fill(0);
  buffer_.fill(0);
  ocr_.fill(0);
  output_.fill(false);
  icr_ = count_ = 0;
  down_ = blocked_ = false;
}

void TimerModel::setWgm(uint8_t wgm) {
  wgm_ = static_cast<uint8_t>(wgm & (wide_ ? 15 : 7));
  mode_ = timerMode(wide_, wgm_);
  // Double buffering off: the comparator uses what was written last (the datasheet leaves a
  // buffered write that is pending across a mode change open; this takes it).
  if (!doubleBuffered()) ocr_ = buffer_;
}

void TimerModel::setCom(int ch, uint8_t com) { com_[ch] = static_cast<uint8_t>(com & 3); }

bool TimerModel::connected(int ch) const {
  const uint8_t com = com_[ch];
  if (com == 0 || mode_.reserved) return false;
  if (com != 1 || !pwm()) return true;
  return ch == 0 && mode_.toggles_a;  // else: normal port operation (8-bit B: reserved)
}

bool TimerModel::hasReservedSetting() const {
  if (mode_.reserved) return true;
  for (int ch = 1; ch < channels_; ++ch)
    if (!wide_ && pwm() && com_[ch] == 1) return true;
  return false;
}

std::string TimerModel::reservedSetting() const {
  if (mode_.reserved) return fmt::format("waveform generation mode {} is reserved", wgm_);
  if (!wide_ && pwm())
    for (int ch = 1; ch < channels_; ++ch)
      if (com_[ch] == 1)
        return fmt::format("COM{} = 01 is reserved in {} mode", static_cast<char>('A' + ch),
                           waveformName(mode_.waveform));
  return {};
}

uint16_t TimerModel::top() const {
  switch (mode_.top) {
    case TopSource::kOcrA: return ocr_[0];
    case TopSource::kIcr: return icr_;
    case TopSource::kFixed: break;
  }
  return mode_.fixed_top;
}

void TimerModel::writeOcr(int ch, uint16_t value) {
  value = static_cast<uint16_t>(value & max_);
  if (mode_.top == TopSource::kFixed) value = static_cast<uint16_t>(value & mode_.fixed_top);
  buffer_[ch] = value;
  if (!doubleBuffered()) ocr_[ch] = value;
}

bool TimerModel::capture(uint16_t count) {
  if (mode_.top == TopSource::kIcr) return false;
  icr_ = count;
  return true;
}

void TimerModel::writeCount(uint16_t value) {
  count_ = static_cast<uint16_t>(value & max_);
  blocked_ = true;
}

bool TimerModel::force(int ch) {
  if (pwm() || com_[ch] == 0) return false;
  TimerTick t;
  const uint8_t com = com_[ch];
  setOutput(ch, com == 1 ? !output_[ch] : com == 3, t);
  return t.outputs != 0;
}

void TimerModel::setOutput(int ch, bool level, TimerTick& t) {
  if (output_[ch] == level) return;
  output_[ch] = level;
  t.outputs = static_cast<uint8_t>(t.outputs | (1u << ch));
}

void TimerModel::updateFromBuffers() { ocr_ = buffer_; }

// The compare units at the tick that leaves `value`, counting up or down (the direction of
// that step: at TOP a phase-correct match acts as a down-counting one, at BOTTOM as an
// up-counting one, which gives the datasheet's constant outputs at OCRnx = TOP and BOTTOM).
void TimerModel::compareMatch(uint16_t value, bool up, TimerTick& t) {
  for (int ch = 0; ch < channels_; ++ch) {
    if (ocr_[ch] != value) continue;
    t.flags = static_cast<uint8_t>(t.flags | compareFlag(ch));
    const uint8_t com = com_[ch];
    if (com == 0) continue;
    if (com == 1) {
      if (!pwm() || (ch == 0 && mode_.toggles_a)) setOutput(ch, !output_[ch], t);
    } else if (!pwm()) {
      setOutput(ch, com == 3, t);  // normal, CTC: clear (10) or set (11)
    } else if (mode_.waveform == Waveform::kFastPwm) {
      setOutput(ch, com == 3, t);  // non-inverting clears, inverting sets
    } else {
      setOutput(ch, (com == 3) == up, t);  // 10: clear up, set down; 11: the opposite
    }
  }
}

TimerTick TimerModel::tick() {
  TimerTick t;
  if (singleSlope())
    tickSingleSlope(t);
  else
    tickDualSlope(t);
  return t;
}

void TimerModel::tickSingleSlope(TimerTick& t) {
  const uint16_t c = count_;
  const bool blocked = blocked_;
  blocked_ = false;
  down_ = false;
  const uint16_t top_value = top();
  if (!blocked) compareMatch(c, true, t);
  // TOP from OCRnA or ICRn is a compare match too: a TCNTn write blocks it, and the counter
  // runs on to MAX (the datasheet's warning about writing TCNTn = TOP).
  const bool at_top = c == top_value && !(blocked && mode_.top != TopSource::kFixed);
  if (at_top) {
    count_ = 0;
    if (mode_.top == TopSource::kIcr) t.flags |= kFlagCapture;  // ICFn at TOP (modes 12, 14)
    if (mode_.waveform == Waveform::kFastPwm) {
      t.flags |= kFlagOverflow;  // TOVn at TOP
      updateFromBuffers();       // "at BOTTOM": the TOP -> BOTTOM edge
      for (int ch = 0; ch < channels_; ++ch)
        if (com_[ch] >= 2) setOutput(ch, com_[ch] == 2, t);  // set (10) / clear (11) at BOTTOM
    } else if (top_value == max_) {
      t.flags |= kFlagOverflow;  // normal, CTC: TOVn at MAX
    }
  } else if (c == max_) {
    count_ = 0;  // a missed TOP: on to MAX and around
    if (mode_.waveform != Waveform::kFastPwm) t.flags |= kFlagOverflow;
  } else {
    count_ = static_cast<uint16_t>(c + 1);
  }
}

void TimerModel::tickDualSlope(TimerTick& t) {
  const uint16_t c = count_;
  const bool blocked = blocked_;
  blocked_ = false;
  const uint16_t top_value = top();
  const bool variable_top = mode_.top != TopSource::kFixed;
  bool top_event = false, bottom_event = false, up = !down_;
  uint16_t next;
  if (top_value == 0 && c == 0 && !blocked) {  // TOP = BOTTOM: the counter stays at 0
    top_event = bottom_event = true;
    up = true;
    next = 0;
  } else if (c == top_value && !(blocked && variable_top)) {
    top_event = true;  // turns (or, coming down from above TOP, goes on down)
    up = false;
    next = static_cast<uint16_t>(c - 1);
  } else if (c == 0 && !blocked) {
    bottom_event = true;
    up = true;
    next = 1;
  } else if (up) {
    next = c == max_ ? 0 : static_cast<uint16_t>(c + 1);  // above TOP: on to MAX and around
  } else {
    next = c == 0 ? max_ : static_cast<uint16_t>(c - 1);  // a blocked BOTTOM: on below 0
  }
  if (!blocked) compareMatch(c, up, t);
  if (top_event) {
    if (mode_.waveform == Waveform::kPhaseCorrect) updateFromBuffers();
    if (mode_.top == TopSource::kIcr) t.flags |= kFlagCapture;
    // At TOP OCnx is what an up-counting match leaves, unless OCRnx equals TOP: the transition
    // "without compare match" the datasheet describes for OCRnx leaving TOP or a counter that
    // started above OCRnx, so that the pulse stays symmetric around BOTTOM.
    const uint16_t new_top = top();
    for (int ch = 0; ch < channels_; ++ch)
      if (com_[ch] >= 2) setOutput(ch, (ocr_[ch] == new_top) == (com_[ch] == 2), t);
  }
  if (bottom_event) {
    t.flags |= kFlagOverflow;  // TOVn at BOTTOM
    if (mode_.waveform == Waveform::kPhaseFrequencyCorrect) updateFromBuffers();
  }
  down_ = !up;
  count_ = next;
}

uint32_t TimerModel::quietTicks() const {
  // The counter moves one step per tick without a turn or a wrap until it leaves one of these
  // values (TOP and MAX bound every run up, TOP and BOTTOM every run down).
  const bool up = singleSlope() || !down_;
  const uint32_t c = count_;
  uint32_t quiet = 0xFFFFFFFFu;
  auto consider = [&](uint32_t v) {
    if (up && v >= c) quiet = std::min(quiet, v - c);
    if (!up && v <= c) quiet = std::min(quiet, c - v);
  };
  for (int ch = 0; ch < channels_; ++ch) consider(ocr_[ch]);
  consider(top());
  consider(max_);
  if (!singleSlope()) consider(0);  // BOTTOM turns a dual-slope counter
  return quiet;
}

void TimerModel::skip(uint32_t ticks) {
  if (ticks == 0) return;
  blocked_ = false;
  const bool up = singleSlope() || !down_;
  count_ = static_cast<uint16_t>(up ? count_ + ticks : count_ - ticks);
  if (singleSlope()) down_ = false;
}

}  // namespace sim

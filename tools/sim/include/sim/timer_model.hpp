// One ATmega2560 Timer/Counter as the datasheet describes it, counted in timer clock ticks: the
// counter and its waveform generation mode (WGM), the compare units with their double-buffered
// OCRnx and their output registers OCnx, ICRn, and the flags a tick sets. No simavr here:
// sim/timers.hpp clocks it from the prescaler and connects it to the core (registers,
// interrupts, pins). docs/sim.md, "Timers", says which rules of the datasheet this follows.
//
// A tick is one edge of the timer clock; the counter holds a value between two ticks. Whatever
// the datasheet ties to a value (a compare match with OCRnx, TOP, BOTTOM, MAX) happens at the
// tick that leaves it ("a match sets the flag at the next timer clock cycle"; the timing
// diagrams set TOVn and update OCRnx at the TOP -> BOTTOM edge). So in fast PWM OCnx is high for
// OCRnx + 1 ticks of TOP + 1, in phase-correct PWM for 2 OCRnx ticks of 2 TOP.
//
// Between two "special" ticks (leaving an OCRnx value, TOP, BOTTOM or MAX) nothing observable
// happens: quietTicks() says how many ticks can be skipped with skip() before the next one,
// which tick() then applies with every rule.
#pragma once
#include <array>
#include <cstdint>
#include <string>

namespace sim {

enum class Waveform : uint8_t { kNormal, kCtc, kFastPwm, kPhaseCorrect, kPhaseFrequencyCorrect };
enum class TopSource : uint8_t { kFixed, kOcrA, kIcr };

// A waveform generation mode as the datasheet's table lists it (16-bit: WGMn3:0, 8-bit:
// WGMn2:0). When OCRnx is updated and when TOVn is set follow from the waveform.
struct TimerMode {
  Waveform waveform = Waveform::kNormal;
  TopSource top = TopSource::kFixed;
  uint16_t fixed_top = 0xFFFF;  // kFixed
  bool reserved = false;
  bool toggles_a = false;  // a PWM mode in which COMnA = 01 toggles OCnA on compare match
};
TimerMode timerMode(bool wide, uint8_t wgm);
const char* waveformName(Waveform w);  // "normal", "CTC", "fast PWM", ...

// What one tick did: the flags it set and the outputs (OCnx) it changed.
constexpr uint8_t kFlagOverflow = 0x01;  // TOVn
constexpr uint8_t kFlagCompareA = 0x02;  // OCFnA; B and C follow
constexpr uint8_t kFlagCapture = 0x10;   // ICFn (set at TOP when ICRn is TOP)
constexpr uint8_t compareFlag(int ch) { return static_cast<uint8_t>(kFlagCompareA << ch); }
struct TimerTick {
  uint8_t flags = 0;
  uint8_t outputs = 0;  // bit ch: OCnx changed
};

class TimerModel {
 public:
  static constexpr int kMaxChannels = 3;
  // An 8-bit (Timer0/2, two compare units) or 16-bit timer (Timer1/3/4/5, three).
  TimerModel(bool wide, int channels);
  void reset();  // as after a chip reset: every register 0, counting up

  // --- configuration (TCCRnA/B) ---
  void setWgm(uint8_t wgm);
  uint8_t wgm() const { return wgm_; }
  const TimerMode& mode() const { return mode_; }
  void setCom(int ch, uint8_t com);
  uint8_t com(int ch) const { return com_[ch]; }
  // OCnx overrides its port pin: the COM setting connects it in this mode (COMnx = 01 does
  // not in most PWM modes).
  bool connected(int ch) const;
  // What the datasheet leaves undefined in the present setting (a reserved mode, a reserved
  // COM value), or "".
  std::string reservedSetting() const;
  bool hasReservedSetting() const;
  bool pwm() const { return mode_.waveform != Waveform::kNormal && mode_.waveform != Waveform::kCtc; }

  // --- registers ---
  // OCRnx: in the PWM modes the write goes to the buffer, which the comparator takes at TOP or
  // BOTTOM; in normal and CTC mode at once. With a fixed TOP the unused high bits are masked.
  void writeOcr(int ch, uint16_t value);
  uint16_t ocr(int ch) const { return buffer_[ch]; }         // what OCRnx reads
  uint16_t activeOcr(int ch) const { return ocr_[ch]; }     // what the comparator uses
  void writeIcr(uint16_t value) { icr_ = static_cast<uint16_t>(value & max_); }
  uint16_t icr() const { return icr_; }
  // An input capture at counter value `count`: ICRn takes it unless ICRn is TOP in this mode
  // (then the capture unit is off). True when it did (the caller sets ICFn).
  bool capture(uint16_t count);
  // TCNTn: a write also blocks every compare match at the next tick, TOP and BOTTOM
  // detection included where they are compare matches (variable TOP, phase-correct BOTTOM).
  void writeCount(uint16_t value);
  uint16_t count() const { return count_; }
  bool countingDown() const { return down_; }
  uint16_t top() const;
  uint16_t max() const { return max_; }
  bool output(int ch) const { return output_[ch]; }
  // FOCnx: in normal and CTC mode OCnx changes as at a compare match (no flag, no clear);
  // ignored in the PWM modes. True when OCnx changed.
  bool force(int ch);

  // --- ticking ---
  TimerTick tick();
  // Ticks from now that change nothing but the counter; the tick after them is special.
  uint32_t quietTicks() const;
  void skip(uint32_t ticks);  // at most quietTicks()

 private:
  bool singleSlope() const { return !pwm() || mode_.waveform == Waveform::kFastPwm; }
  bool doubleBuffered() const { return pwm(); }
  void tickSingleSlope(TimerTick& t);
  void tickDualSlope(TimerTick& t);
  void compareMatch(uint16_t value, bool up, TimerTick& t);
  void setOutput(int ch, bool level, TimerTick& t);
  void updateFromBuffers();

  bool wide_;
  int channels_;
  uint16_t max_;
  uint8_t wgm_ = 0;
  TimerMode mode_;
  std::array<uint8_t, kMaxChannels> com_{};
  std::array<uint16_t, kMaxChannels> buffer_{};
  std::array<uint16_t, kMaxChannels> ocr_{};
  std::array<bool, kMaxChannels> output_{};
  uint16_t icr_ = 0;
  uint16_t count_ = 0;
  bool down_ = false;     // dual slope: counting down
  bool blocked_ = false;  // TCNTn was written: the next tick matches nothing
};

}  // namespace sim

// The AVR HAL (hal/avr) as the real gather_store image uses it, run in simavr 1.6: ESC pulses
// on the four compare pins, the 1 kHz clock against simulated cycles, the UART both ways, the
// ADC with its interrupt wake-up, the EEPROM, and idle sleep. A minimal libsimavr harness of
// its own (no dependency on tools/sim) so a HAL regression shows up here, by name.
// Budgets are simulated cycles only: deterministic, no wall-clock assertions.
#include "sim/lsan_simavr.hpp"
#include <gtest/gtest.h>

#include <simavr/avr_adc.h>
#include <simavr/avr_eeprom.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>

#include <cmath>
#include <cstring>
#include <deque>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "hal/board.hpp"
#include "text_match.hpp"
#include "thrustcal/eeprom_codec.hpp"

#ifndef GATHER_STORE_ELF
#define GATHER_STORE_ELF ""
#endif
#ifndef READ_RUN_ELF
#define READ_RUN_ELF ""
#endif

namespace {

constexpr double kCpuHz = hal::kCpuHz;  // the board table (hal/board.hpp)
constexpr avr_cycle_count_t kCyclesPerUartByte = 1389;  // 10 bits at 115200 baud
// Pulse widths: simavr timestamps pin edges between instructions, so an edge may land up to
// 4 cycles (0.25 us) late; one timer tick off (OCR off by one) is 0.5 us and still fails.
constexpr double kWidthTolUs = 0.3;

struct Pulse {
  avr_cycle_count_t rise;
  double width_us;
};

class SimBoard {
 public:
  explicit SimBoard(const char* elf_path, std::string prompt = "gs> ") : prompt_(std::move(prompt)) {
    if (elf_read_firmware(elf_path, &firmware_) != 0) return;
    avr_ = avr_make_mcu_by_name("atmega2560");
    if (avr_ == nullptr) return;
    avr_init(avr_);
    avr_load_firmware(avr_, &firmware_);
    avr_->sleep = [](avr_t*, avr_cycle_count_t) {};  // no real-time pacing
    uint32_t flags = 0;
    avr_ioctl(avr_, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~(AVR_UART_FLAG_POLL_SLEEP | AVR_UART_FLAG_STDIO);
    avr_ioctl(avr_, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            &SimBoard::onUartOut, this);
    uart_in_ = avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    for (int ch = 0; ch < 4; ++ch) {  // the pins the board table names (hal/board.hpp)
      pin_ctx_[ch] = {this, ch};
      avr_irq_register_notify(
          avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(hal::kEscPins[ch].port), hal::kEscPins[ch].bit),
          &SimBoard::onPin, &pin_ctx_[ch]);
    }
    adc_[0] = avr_io_getirq(avr_, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0);
    adc_[1] = avr_io_getirq(avr_, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC1);
    avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_OUT_TRIGGER),
                            &SimBoard::onAdcTrigger, this);
  }
  ~SimBoard() {
    if (avr_ != nullptr) avr_terminate(avr_);
  }
  SimBoard(const SimBoard&) = delete;
  SimBoard& operator=(const SimBoard&) = delete;

  bool ok() const { return avr_ != nullptr; }
  const elf_firmware_t& firmware() const { return firmware_; }
  avr_cycle_count_t cycle() const { return avr_->cycle; }
  double seconds() const { return avr_->cycle / kCpuHz; }

  // (channel, millivolts) for A0 and A1, asked on every conversion.
  std::function<double(int channel)> adc_mv = [](int) { return 2500.0; };

  // Runs `cycles` more simulated cycles; returns the number of avr_run() steps it took.
  uint64_t runCycles(avr_cycle_count_t cycles) {
    const avr_cycle_count_t end = avr_->cycle + cycles;
    uint64_t steps = 0;
    while (avr_->cycle < end) {
      step();
      ++steps;
    }
    return steps;
  }
  // Runs until `text` appears in the output after `from`; false when the budget runs out.
  bool runUntil(const std::string& text, double budget_s, size_t from = 0) {
    const avr_cycle_count_t end = avr_->cycle + static_cast<avr_cycle_count_t>(budget_s * kCpuHz);
    while (avr_->cycle < end) {
      if (out_.find(text, from) != std::string::npos) return true;
      step();
    }
    return out_.find(text, from) != std::string::npos;
  }
  // Sends `line` + CR at the UART's byte rate and runs until the next prompt.
  std::string command(const std::string& line, double budget_s = 2.0) {
    const size_t from = out_.size();
    send(line + "\r");
    EXPECT_TRUE(runUntil(prompt_, budget_s, from)) << "no prompt after '" << line << "':\n"
                                                    << out_.substr(from);
    return out_.substr(from);
  }
  void send(const std::string& bytes) {
    for (char c : bytes) pending_in_.push_back(static_cast<uint8_t>(c));
  }

  const std::string& output() const { return out_; }
  // Simulated time (s) at which output byte `index` was written to UDR0.
  double outputSeconds(size_t index) const { return out_cycles_.at(index) / kCpuHz; }
  const std::vector<Pulse>& pulses(int channel) const { return pulses_[channel]; }
  double lastPeriodUs(int channel) const {
    const auto& p = pulses_[channel];
    return p.size() < 2 ? 0.0 : (p.back().rise - p[p.size() - 2].rise) * 1e6 / kCpuHz;
  }
  double lastPulseUs(int channel) const {
    return pulses_[channel].empty() ? 0.0 : pulses_[channel].back().width_us;
  }
  std::vector<uint8_t> eeprom() {
    std::vector<uint8_t> bytes(4096);
    avr_eeprom_desc_t desc{bytes.data(), 0, static_cast<uint32_t>(bytes.size())};
    avr_ioctl(avr_, AVR_IOCTL_EEPROM_GET, &desc);
    if (desc.ee != bytes.data()) std::memcpy(bytes.data(), desc.ee, bytes.size());
    return bytes;
  }

 private:
  struct PinCtx {
    SimBoard* board;
    int channel;
  };

  void step() {
    if (!pending_in_.empty() && avr_->cycle >= next_in_cycle_) {
      avr_raise_irq(uart_in_, pending_in_.front());
      pending_in_.pop_front();
      next_in_cycle_ = avr_->cycle + kCyclesPerUartByte;
    }
    const int state = avr_run(avr_);
    if (state == cpu_Done || state == cpu_Crashed) {
      ADD_FAILURE() << "AVR stopped (state " << state << ") at cycle " << avr_->cycle;
      avr_->cycle = ~avr_cycle_count_t(0) / 2;  // ends every loop
    }
  }

  static void onUartOut(avr_irq_t*, uint32_t value, void* param) {
    auto* b = static_cast<SimBoard*>(param);
    b->out_.push_back(static_cast<char>(value));
    b->out_cycles_.push_back(b->avr_->cycle);
  }
  static void onPin(avr_irq_t*, uint32_t value, void* param) {
    auto* ctx = static_cast<PinCtx*>(param);
    SimBoard& b = *ctx->board;
    if (value) {
      b.rise_[ctx->channel] = b.avr_->cycle;
    } else if (b.rise_[ctx->channel] != 0) {
      b.pulses_[ctx->channel].push_back(
          {b.rise_[ctx->channel], (b.avr_->cycle - b.rise_[ctx->channel]) * 1e6 / kCpuHz});
    }
  }
  static void onAdcTrigger(avr_irq_t*, uint32_t, void* param) {
    auto* b = static_cast<SimBoard*>(param);
    for (int ch = 0; ch < 2; ++ch) {
      avr_raise_irq(b->adc_[ch], static_cast<uint32_t>(std::lround(b->adc_mv(ch))));
    }
  }

  std::string prompt_;
  elf_firmware_t firmware_ = {};
  avr_t* avr_ = nullptr;
  avr_irq_t* uart_in_ = nullptr;
  avr_irq_t* adc_[2] = {};
  PinCtx pin_ctx_[4] = {};
  std::string out_;
  std::vector<avr_cycle_count_t> out_cycles_;  // when each output byte was written
  std::deque<uint8_t> pending_in_;
  avr_cycle_count_t next_in_cycle_ = 0;
  avr_cycle_count_t rise_[4] = {};
  std::vector<Pulse> pulses_[4];
};

// A linear stand-in plant on ESC `channel`: thrust grows 1 g per us above 1100 us; the
// amplifier gives 1 count per 0.75 g (thesis line) from a base of 200 counts; the battery
// monitor reads 12.0 V minus 1 mV per gram.
struct LinearPlant {
  int channel = 0;
  double thrustG(double pulse_us) const { return pulse_us > 1100 ? pulse_us - 1100 : 0.0; }
};

class AvrHalSim : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string path = GATHER_STORE_ELF;
    if (path.empty() || !std::ifstream(path).good()) {
      GTEST_SKIP() << "no AVR image at '" << path
                   << "': build the AVR tree first (cmake --preset avr && cmake --build "
                      "--preset avr) or set THRUSTCAL_AVR_BUILD_DIR";
    }
    board_ = std::make_unique<SimBoard>(path.c_str());
    ASSERT_TRUE(board_->ok()) << "simavr could not load " << path;
    board_->adc_mv = [this](int ch) {
      const double thrust = plant_.thrustG(board_->lastPulseUs(plant_.channel));
      if (ch == 0) return (200.0 + thrust / 0.75) * 5000.0 / 1023.0;
      return (12000.0 - thrust) * 47.0 / 147.0;
    };
    ASSERT_TRUE(board_->runUntil("gs> ", 0.2)) << board_->output();
  }
  std::unique_ptr<SimBoard> board_;
  LinearPlant plant_;
};

TEST_F(AvrHalSim, ImageCarriesTheSimavrTagForTheAtmega2560) {
  EXPECT_STREQ(board_->firmware().mmcu, "atmega2560");
  EXPECT_EQ(board_->firmware().frequency, 16000000u);
  EXPECT_EQ(board_->firmware().vcc, 5000u);
  EXPECT_EQ(board_->firmware().avcc, 5000u);
}

TEST_F(AvrHalSim, UartPrintsTheBannerFromFlashWithinTheFirstTenthOfASecond) {
  EXPECT_NE(board_->output().find("thrustcal gather_store"), std::string::npos);
  EXPECT_LT(board_->seconds(), 0.1);
}

TEST_F(AvrHalSim, AllFourEscPinsPulse1000usAt50Hz) {
  board_->runCycles(static_cast<avr_cycle_count_t>(0.1 * kCpuHz));
  for (int ch = 0; ch < 4; ++ch) {
    const auto& p = board_->pulses(ch);
    ASSERT_GE(p.size(), 4u) << "channel " << ch;
    EXPECT_NEAR(p.back().width_us, 1000.0, kWidthTolUs) << "channel " << ch;  // OCR + 1 = 2000 ticks
    const double period_us = (p.back().rise - p[p.size() - 2].rise) * 1e6 / kCpuHz;
    EXPECT_NEAR(period_us, 20000.0, kWidthTolUs) << "channel " << ch;  // ICR + 1 = 40000 ticks
  }
}

TEST_F(AvrHalSim, UartReceivesAndEchoesACommand) {
  const std::string out = board_->command("motor 3");
  EXPECT_NE(out.find("motor 3\r\n"), std::string::npos) << out;  // echo
  EXPECT_NE(out.find("motor 3 selected: ESC D11 (PB5, OC1A)"), std::string::npos) << out;
}

class AvrHalSimSlot : public AvrHalSim, public ::testing::WithParamInterface<int> {};

TEST_P(AvrHalSimSlot, SweepDrivesTheSelectedPinAndReadsTheAdcOnTheMillisecondClock) {
  // given: motor N (D6, D7, D8, D11), three steps of 100 us, 100 ms settle
  const int ch = GetParam();
  plant_.channel = ch;
  board_->command("motor " + std::to_string(ch));
  board_->command("range 1100 1300");
  board_->command("step 100");
  board_->command("settle 100");
  board_->runCycles(static_cast<avr_cycle_count_t>(2.0 * kCpuHz));  // past the arming time
  board_->command("tare");
  const size_t pulses_before = board_->pulses(ch).size();
  // when
  const size_t out_from = board_->output().size();
  const std::string out = board_->command("sweep", 3.0);
  board_->runCycles(static_cast<avr_cycle_count_t>(0.05 * kCpuHz));
  // then: the pin carried exactly the swept widths, and 1000 us again at the end. simavr 1.6's
  // own timer (this harness's) applies an OCRnx write at once, where the chip buffers it until
  // BOTTOM in mode 14: a shorter width written while the pin is high and the counter already
  // past it misses its compare match, and that one pulse lasts a frame plus the new width. Only
  // that signature is set aside, at most once per width change (tools/sim's board models the
  // buffer; tests/timers checks it).
  std::vector<double> widths;
  int missed_compares = 0;
  const auto& pulses = board_->pulses(ch);
  for (size_t i = pulses_before; i < pulses.size(); ++i) {
    const double w = pulses[i].width_us;
    if (i + 1 < pulses.size() && std::fabs(w - (20000.0 + pulses[i + 1].width_us)) < 0.5) {
      ++missed_compares;
      continue;
    }
    if (widths.empty() && std::fabs(w - 1000.0) < 0.5) continue;  // frames before step 1
    if (widths.empty() || std::fabs(widths.back() - w) > 0.5) widths.push_back(w);
  }
  EXPECT_LE(missed_compares, 1);
  std::string seen;
  for (double w : widths) seen += std::to_string(w) + " ";
  ASSERT_EQ(widths.size(), 4u) << seen << "\n" << out;
  EXPECT_NEAR(widths[0], 1100.0, kWidthTolUs);
  EXPECT_NEAR(widths[1], 1200.0, kWidthTolUs);
  EXPECT_NEAR(widths[2], 1300.0, kWidthTolUs);
  EXPECT_NEAR(widths[3], 1000.0, kWidthTolUs);
  for (int other = 0; other < 4; ++other) {  // the other three ESCs stay at 1000 us
    if (other == ch) continue;
    for (const auto& p : board_->pulses(other)) EXPECT_NEAR(p.width_us, 1000.0, kWidthTolUs) << other;
  }
  // CSV rows: force from A0 through the thesis line (1 count = 0.75 g, so 100 g = 133.3
  // counts reads 99.75 or 100.5 g), battery from A1, time from the millisecond clock.
  const tc::test::Pattern row("(\\d+),(-?\\d+\\.\\d),(\\d+\\.\\d{3}),(\\d+\\.\\d{3})," +
                              std::to_string(ch) + ",1");
  std::vector<double> force, vbat, t, printed_s;
  for (const tc::test::Groups& m : row.allIn(out)) {
    force.push_back(std::stod(m[2]));
    vbat.push_back(std::stod(m[3]));
    t.push_back(std::stod(m[4]));
    printed_s.push_back(board_->outputSeconds(out_from + m.position));
  }
  ASSERT_EQ(force.size(), 3u) << out;
  EXPECT_NEAR(force[0], 0.0, 0.8);
  EXPECT_NEAR(force[1], 100.0, 0.8);
  EXPECT_NEAR(force[2], 200.0, 0.8);
  EXPECT_NEAR(vbat[0], 12.000, 0.025);
  EXPECT_NEAR(vbat[2], 11.800, 0.025);
  // Clock: the firmware's t_s between rows (Timer0 milliseconds) equals the simulated time
  // between the rows leaving the UART, within 2 ms (1 ms tick granularity at each end); a
  // clock 2 % off would drift 3 ms per step. Each step is 100 ms settle + 302 conversions
  // of 13 ADC clocks at 125 kHz (31.4 ms) with a median insertion after each + the CSV line.
  for (size_t i = 1; i < t.size(); ++i) {
    const double real_dt = printed_s[i] - printed_s[i - 1];
    EXPECT_NEAR(t[i] - t[i - 1], real_dt, 0.002) << i;
    EXPECT_GT(real_dt, 0.100 + 0.031) << i;
    EXPECT_LT(real_dt, 0.100 + 0.050) << i;
  }
}

INSTANTIATE_TEST_SUITE_P(EachEscOutput, AvrHalSimSlot, ::testing::Values(0, 1, 2, 3));

TEST_F(AvrHalSim, AKeyStopsTheMotorFromTheNextFrameOn) {
  // given: a slow sweep under way at 1300 us or more
  board_->command("range 1300 1800");
  board_->command("settle 2000");
  board_->runCycles(static_cast<avr_cycle_count_t>(2.0 * kCpuHz));
  board_->command("tare");
  board_->send("sweep\r");
  ASSERT_TRUE(board_->runUntil("pwm_us,force_g", 0.5));
  board_->runCycles(static_cast<avr_cycle_count_t>(0.5 * kCpuHz));
  ASSERT_NEAR(board_->lastPulseUs(0), 1300.0, kWidthTolUs);
  // when: one byte arrives
  const size_t from = board_->output().size();
  board_->send("x");
  const avr_cycle_count_t sent = board_->cycle();
  ASSERT_TRUE(board_->runUntil("gs> ", 0.5, from));
  board_->runCycles(static_cast<avr_cycle_count_t>(0.1 * kCpuHz));
  // then: every pulse that starts more than one frame after the byte is 1000 us
  int checked = 0;
  for (const auto& p : board_->pulses(0)) {
    if (p.rise > sent + static_cast<avr_cycle_count_t>(0.020 * kCpuHz)) {
      EXPECT_NEAR(p.width_us, 1000.0, kWidthTolUs);
      ++checked;
    }
  }
  EXPECT_GE(checked, 3);
  EXPECT_NE(board_->output().find("# aborted: key pressed", from), std::string::npos);
}

TEST_F(AvrHalSim, StoredRecordIsInTheSimulatedEepromAndDecodes) {
  // given: a short sweep on motor 0
  board_->command("range 1100 1500");
  board_->command("step 20");
  board_->command("settle 20");
  board_->runCycles(static_cast<avr_cycle_count_t>(2.0 * kCpuHz));
  board_->command("tare");
  ASSERT_NE(board_->command("sweep", 5.0).find("# next: store 1"), std::string::npos)
      << board_->output();
  // when
  const std::string out = board_->command("store 1", 6.0);  // 3.4 ms per changed byte on chip
  // then
  EXPECT_NE(out.find("stored curve 1 of motor 0"), std::string::npos) << out;
  static std::vector<uint8_t> image;
  image = board_->eeprom();
  struct RamStorage {
    static uint8_t readByte(uint16_t addr) { return image[addr]; }
    static void updateByte(uint16_t addr, uint8_t value) { image[addr] = value; }
  };
  tc::MotorCalibration cal;
  ASSERT_EQ(tc::readRecord<RamStorage>(0, cal), tc::DecodeStatus::kOk);
  EXPECT_NEAR(cal.first.start_mv, 12000, 40);  // bin 0: 0..20 g of sag, one count 15 mV
  // 1 g per us up to 1500 us; 400 g is 533.3 counts, read as 533 = 399.75 g
  EXPECT_EQ(cal.first.maxGrams(), 399u);
  for (uint16_t g = 10; g <= 390; g += 10) {
    EXPECT_NEAR(cal.first.pwmForGrams(g), 1100.0 + g, 2.0) << g << " g";
  }
  EXPECT_EQ(image[1024], 0xFF);  // slot 1 untouched
}

TEST_F(AvrHalSim, IdleFirmwareSleepsBetweenTicks) {
  // One simulated second with nothing to do: a busy loop would need about 16e6 / 1.5
  // instruction steps; asleep, the core only runs the 1 kHz tick and wakes briefly.
  const uint64_t steps = board_->runCycles(static_cast<avr_cycle_count_t>(1.0 * kCpuHz));
  RecordProperty("idle_steps_per_simulated_second", std::to_string(steps));
  EXPECT_LT(steps, 200000u);
}

// Esc::setFrameRate through the read_run image's "rate" command (gather_store keeps 50 Hz):
// ICR changes on both timers and the counters restart, so every pin keeps its 1000 us pulse.
struct RateRow {
  int hz;
  double period_us;
};

TEST(AvrHalSimFrameRate, RateChangesThePeriodOnAllFourPinsAndKeepsThePulse) {
  const std::string path = READ_RUN_ELF;
  if (path.empty() || !std::ifstream(path).good()) {
    GTEST_SKIP() << "no AVR image at '" << path << "': build the AVR tree first";
  }
  SimBoard board(path.c_str(), "rr> ");
  ASSERT_TRUE(board.ok());
  board.adc_mv = [](int channel) { return channel == 1 ? 12000.0 * 47.0 / 147.0 : 1000.0; };
  ASSERT_TRUE(board.runUntil("rr> ", 3.0)) << board.output();  // after the 2 s arming
  for (const RateRow row : {RateRow{400, 2500.0}, RateRow{200, 5000.0}, RateRow{50, 20000.0}}) {
    const std::string out = board.command("rate " + std::to_string(row.hz));
    ASSERT_NE(out.find("frame rate " + std::to_string(row.hz) + " Hz"), std::string::npos) << out;
    board.runCycles(static_cast<avr_cycle_count_t>(0.1 * kCpuHz));
    for (int ch = 0; ch < 4; ++ch) {
      EXPECT_NEAR(board.lastPeriodUs(ch), row.period_us, kWidthTolUs) << row.hz << " Hz, channel " << ch;
      EXPECT_NEAR(board.lastPulseUs(ch), 1000.0, kWidthTolUs) << row.hz << " Hz, channel " << ch;
    }
  }
  // and no pulse was stretched or cut while the frame changed under it
  for (int ch = 0; ch < 4; ++ch) {
    for (const auto& p : board.pulses(ch)) {
      EXPECT_NEAR(p.width_us, 1000.0, kWidthTolUs) << "channel " << ch << " at " << p.rise / kCpuHz << " s";
    }
  }
}

}  // namespace

// Benchmarks 11 and 12: the virtual airframe's I2C bus and IMU, whose figures docs/sim.md
// generates ("The TWI" and "The MPU-6050").
//  11. twi: the test image air_probe (tests/airframe/air_probe, built here with avr-gcc) in
//      simavr with the MPU-6050 on the board's own TWI: a 14-byte burst from ACCEL_XOUT_H and a
//      one-register read (WHO_AM_I) with air_probe's polled and interrupt-driven drivers, at
//      400 kHz, 100 kHz and 100 kHz through the prescaler. The bus time the model takes (the sum
//      of its operations in the TWI's trace) against the datasheet's formula, and the software
//      time each driver adds per bus operation (air_probe's own Timer5 count minus the bus time).
//  12. imu: the MPU-6050 model's DLPF settings measured on the chip model (sim/mpu6050_dlpf.hpp,
//      what `thrustcal sim imu` prints) beside the datasheet's table (Mpu6050::gyroDlpf/accelDlpf).
// Both take about a second.
#include <cmath>
#include <filesystem>
#include <numbers>
#include <regex>

#include <fmt/format.h>

#include "bench/sections.hpp"

#ifdef THRUSTCAL_BENCH_HAVE_SIM
#include "hal/board.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/imu_on_board.hpp"
#include "sim/mpu6050_dlpf.hpp"
#include "sim/twi.hpp"
#endif

namespace bench {

#ifndef THRUSTCAL_BENCH_HAVE_SIM

Section twiSection() {
  return unavailableSection("twi", "11. TWI", "tools/sim (thrustcal_sim) is not part of this build: no simulated board");
}
Section imuSection() {
  return unavailableSection("imu", "12. MPU-6050 DLPF",
                            "tools/sim (thrustcal_sim) is not part of this build: no MPU-6050 model");
}

#else

namespace {

#ifdef THRUSTCAL_BENCH_AIR_PROBE_ELF
const char* const kAirProbeElf = THRUSTCAL_BENCH_AIR_PROBE_ELF;
#else
const char* const kAirProbeElf = "";
#endif

// The TwiTiming test's bound: what a driver may spend in software around each bus operation.
constexpr double kMaxSoftwareCyclesPerOp = 120.0;
constexpr uint32_t kTwiStandardHz = 100000;  // I2C standard mode, the benchmark's second rate
constexpr uint8_t kAccelXoutH = 0x3B, kWhoAmIReg = 0x75, kPwrMgmt1 = 0x6B;
constexpr int kBurstBytes = 14;

struct BusRate {
  uint8_t twbr, twps;
};

struct Read {
  std::string what;
  uint8_t reg;
  int bytes;
};

struct TwiRow {
  std::string read;
  BusRate rate{};
  int ops = 0;                  // bus operations: bytes (9 bits each) and conditions (1 bit)
  uint64_t bus_bits = 0;        // bytes * 9 + conditions
  uint64_t bit_cycles_hand = 0;  // 16 + 2 TWBR 4^TWPS
  uint64_t bus_hand = 0, bus_model = 0, polled = 0, interrupt = 0;
  double polledPerOp() const { return static_cast<double>(polled - bus_model) / ops; }
  double interruptPerOp() const { return static_cast<double>(interrupt - bus_model) / ops; }
};

// air_probe's answer to `rd|ri REG N`: every TWI status in order, then its own cycle count.
uint64_t driverCycles(sim::Console& console, const std::string& cmd, const Read& r) {
  const std::string line = fmt::format("{} {} {}", cmd, r.reg, r.bytes);
  const std::vector<std::string> out = console.command(line, 0.5);
  // START, SLA+W acked, register acked, repeated START, SLA+R acked, (N-1) data acked, last nacked
  const std::regex want(fmt::format(R"(st 08 18 28 10 40( 50){{{}}} 58 cyc (\d+).*)", r.bytes - 1));
  std::smatch m;
  if (out.empty() || !std::regex_match(out[0], m, want))
    throw std::runtime_error(fmt::format("air_probe's `{}` did not read the MPU-6050 as the chip would: \"{}\"", line,
                                         out.empty() ? "(no answer)" : out[0]));
  return std::stoull(m[2]);
}

// The model's bus time: each operation from its start to the status that ends it.
uint64_t busCycles(const std::vector<sim::TwiEvent>& trace) {
  uint64_t sum = 0;
  for (std::size_t i = 0; i + 1 < trace.size(); ++i)
    if (trace[i].what == sim::TwiEvent::What::kOpStart && trace[i + 1].what == sim::TwiEvent::What::kStatus)
      sum += trace[i + 1].cycle - trace[i].cycle;
  return sum;
}

TwiRow measureRead(sim::Board& board, sim::Console& console, const BusRate& rate, const Read& r) {
  TwiRow row;
  row.read = r.what;
  row.rate = rate;
  const int bytes = 3 + r.bytes, conditions = 3;  // SLA+W, register, SLA+R, data; START, rep. START, STOP
  row.ops = bytes + conditions;
  row.bus_bits = static_cast<uint64_t>(bytes) * 9 + conditions;
  row.bit_cycles_hand = 16u + 2u * rate.twbr * (1u << (2u * rate.twps));
  row.bus_hand = row.bus_bits * row.bit_cycles_hand;
  sim::Twi& twi = board.twi();
  twi.clearTrace();
  twi.setTracing(true);
  row.polled = driverCycles(console, "rd", r);
  twi.setTracing(false);
  row.bus_model = busCycles(twi.trace());
  twi.clearTrace();
  twi.setTracing(true);
  row.interrupt = driverCycles(console, "ri", r);
  twi.setTracing(false);
  const uint64_t bus_interrupt = busCycles(twi.trace());
  if (bus_interrupt != row.bus_model)
    throw std::runtime_error(fmt::format("the TWI took {} cycles for the polled read and {} for the interrupt-driven "
                                         "one of the same bytes: the bus time must not depend on the driver",
                                         row.bus_model, bus_interrupt));
  return row;
}

std::vector<TwiRow> measureTwi(const std::string& elf) {
  sim::Board board(elf);
  sim::Mpu6050Params ideal;
  ideal.unit_errors = false;
  ideal.noise = false;
  sim::ImuOnBoard imu(board, ideal, sim::levelAtRest());
  sim::Console console(board, "a> ");
  console.waitPrompt(0.1);
  console.command(fmt::format("wr {} 0", kPwrMgmt1), 0.5);  // the IMU leaves sleep
  const uint8_t fast = hal::board::twiBitRateRegister(hal::kTwiFastHz);
  const uint8_t standard = hal::board::twiBitRateRegister(kTwiStandardHz);
  const std::vector<BusRate> rates = {{fast, 0}, {standard, 0}, {static_cast<uint8_t>(standard / 4), 1}};
  const std::vector<Read> reads = {{"14-byte burst from 0x3B (ACCEL_XOUT_H)", kAccelXoutH, kBurstBytes},
                                   {"one register (WHO_AM_I)", kWhoAmIReg, 1}};
  std::vector<TwiRow> rows;
  for (const BusRate& rate : rates) {
    console.command(fmt::format("rate {} {}", rate.twbr, rate.twps), 0.5);
    if (board.twi().bitCycles() != 16u + 2u * rate.twbr * (1u << (2u * rate.twps)))
      throw std::runtime_error(fmt::format("air_probe's `rate {} {}` did not reach TWBR/TWSR", rate.twbr, rate.twps));
    for (const Read& r : reads) rows.push_back(measureRead(board, console, rate, r));
  }
  return rows;
}

std::string rateText(const BusRate& r) {
  return fmt::format("{} kHz (TWBR {}, TWPS {})", hal::board::twiSclHz(r.twbr, r.twps) / 1000, r.twbr, r.twps);
}

// "26,756 cycles", as the docs write whole numbers.
std::string cyclesText(uint64_t cycles) {
  std::string digits = std::to_string(cycles);
  for (int k = static_cast<int>(digits.size()) - 3; k > 0; k -= 3) digits.insert(static_cast<std::size_t>(k), ",");
  return digits + " cycles";
}

}  // namespace

// long: one table, its JSON rows and two targets from the same measurement
Section twiSection() {
  const std::string elf = kAirProbeElf;
  if (elf.empty() || !std::filesystem::exists(elf))
    return unavailableSection("twi", "11. TWI",
                              (elf.empty() ? std::string("air_probe") : elf) +
                                  " not built (avr-gcc missing?): build the host tree's thrustcal target");
  Section s;
  s.key = "twi";
  const std::vector<TwiRow> rows = measureTwi(elf);
  Table t("11. TWI: the MPU-6050 read by air_probe in simavr, bus time and driver cycles",
          {"read (START ... STOP)", "bus rate", "bus time, hand", "bus time (model)", "polled driver",
           "interrupt-driven", "software per bus operation (polled / interrupt)", "target", "met?"});
  s.json["rows"] = nlohmann::json::array();
  int equal = 0;
  double worst_per_op = 0;
  std::string worst;
  for (const TwiRow& r : rows) {
    const bool bus_ok = r.bus_model == r.bus_hand;
    const double per_op = std::max(r.polledPerOp(), r.interruptPerOp());
    const bool met = bus_ok && per_op <= kMaxSoftwareCyclesPerOp;
    equal += bus_ok;
    if (per_op >= worst_per_op) worst_per_op = per_op, worst = r.read + ", " + rateText(r.rate);
    t.addRow({r.read, rateText(r.rate), cyclesText(r.bus_hand), cyclesText(r.bus_model), cyclesText(r.polled),
              cyclesText(r.interrupt), fmt::format("{:.0f} / {:.0f} cycles", r.polledPerOp(), r.interruptPerOp()),
              fmt::format("model = hand; <= {:.0f} cycles", kMaxSoftwareCyclesPerOp), verdict(met)});
    s.json["rows"].push_back({{"read", r.read},
                              {"bytes", r.read.rfind("one", 0) == 0 ? 1 : kBurstBytes},
                              {"scl_hz", hal::board::twiSclHz(r.rate.twbr, r.rate.twps)},
                              {"twbr", r.rate.twbr},
                              {"twps", r.rate.twps},
                              {"bus_operations", r.ops},
                              {"bus_bits", r.bus_bits},
                              {"bit_cycles_hand", r.bit_cycles_hand},
                              {"bus_cycles_hand", r.bus_hand},
                              {"bus_cycles_model", r.bus_model},
                              {"polled_cycles", r.polled},
                              {"interrupt_cycles", r.interrupt},
                              {"polled_software_cycles_per_op", r.polledPerOp()},
                              {"interrupt_software_cycles_per_op", r.interruptPerOp()}});
  }
  t.addNote("hand: (9 bits per byte and its (N)ACK + 1 per START, repeated START, STOP) x (16 + 2 TWBR 4^TWPS) "
            "cycles (ATmega2560 datasheet 24.5.2); a burst of N bytes is SLA+W, the register, SLA+R and N data "
            "bytes with 3 conditions: 14 bytes 156 bits, one register 39 bits");
  t.addNote("model: the board's TWI (tools/sim/src/twi.cpp), each operation from its start to its status, from the "
            "TWI's trace; the same for both drivers");
  t.addNote("drivers: air_probe's own count (Timer5 at clk/1) around `rd REG N` (polled) and `ri REG N` "
            "(TWI interrupt); software per operation = (driver - bus time) / operations (20 for the burst, 7 for "
            "one register); target as test TwiTiming's bound");
  s.tables.push_back(t);
  s.json["elf"] = shownPath(elf);
  s.json["max_software_cycles_per_op"] = kMaxSoftwareCyclesPerOp;
  s.json["worst_software_cycles_per_op"] = worst_per_op;
  const int n = static_cast<int>(rows.size());
  s.targets.push_back(TargetCheck{"TWI bus time against the datasheet's formula (14-byte burst and one register at "
                                  "400 kHz, 100 kHz and 100 kHz through TWPS 1)",
                                  fmt::format("{} of {} equal to the cycle", equal, n), "every read equal",
                                  equal == n});
  s.targets.push_back(TargetCheck{"air_probe's TWI drivers: software cycles per bus operation",
                                  fmt::format("worst {:.0f} cycles ({})", worst_per_op, worst),
                                  fmt::format("<= {:.0f} cycles", kMaxSoftwareCyclesPerOp),
                                  worst_per_op <= kMaxSoftwareCyclesPerOp});
  return s;
}

namespace {

constexpr double kDelayWithinMs = 0.05;     // the model's delay against the table's
constexpr double kGyroBandwidthWithinPct = 10.0;  // first-order settings: -3 dB this close to the table

nlohmann::json measuredJson(const sim::DlpfMeasured& m, const sim::Mpu6050::DlpfRow& table, double noise_scale) {
  nlohmann::json j = {{"table_bandwidth_hz", table.bandwidth_hz},
                      {"table_delay_ms", table.delay_s * 1e3},
                      {"delay_ms", m.delay_ms},
                      {"delay_error_ms", m.delay_ms - table.delay_s * 1e3},
                      {"unfiltered", m.above_search},
                      {"noise_rms", m.noise_rms * noise_scale}};
  if (m.above_search)
    j["above_hz"] = m.search_max_hz;  // no -3 dB point up to the search's end
  else
    j["bandwidth_hz"] = m.bandwidth_hz, j["bandwidth_pct_of_table"] = 100.0 * m.bandwidth_hz / table.bandwidth_hz;
  return j;
}

std::string tableCell(const sim::Mpu6050::DlpfRow& r) {
  const double ms = r.delay_s * 1e3;  // as the datasheet writes it: 0.98, 1.9, 2.0, 13.4
  return fmt::format("{:.0f} Hz / {:.{}f} ms", r.bandwidth_hz, ms, ms > 0 && ms < 1 ? 2 : 1);
}

std::string modelCell(const sim::DlpfMeasured& m) {
  const std::string bw = m.above_search ? fmt::format("above {:.0f} Hz (unfiltered)", m.search_max_hz)
                                        : fmt::format("{:.0f} Hz", m.bandwidth_hz);
  return fmt::format("{} / {:.2f} ms", bw, m.delay_ms);
}

// The gyro's -3 dB against the table: within kGyroBandwidthWithinPct where a first-order
// low-pass at the table's bandwidth fits in the table's delay, at or above it where the model
// widened the low-pass to meet the delay (the table's -3 dB point is then below the model's).
bool gyroBandwidthMet(const sim::DlpfSetting& r, bool widened) {
  if (r.gyro.above_search) return false;
  const double pct = 100.0 * (r.gyro.bandwidth_hz / r.gyro_table.bandwidth_hz - 1.0);
  return widened ? pct >= 0 : std::abs(pct) <= kGyroBandwidthWithinPct;
}

}  // namespace

// long: one table, its JSON rows and two targets from the same measurement
Section imuSection() {
  Section s;
  s.key = "imu";
  const std::vector<sim::DlpfSetting> rows = sim::measureDlpfTable();
  Table t("12. MPU-6050 DLPF: the model against the datasheet's table (chip model only)",
          {"DLPF_CFG", "gyro table", "gyro model", "gyro noise", "accel table", "accel model", "accel noise",
           "met? (delay, gyro -3 dB)"});
  s.json["dlpf"] = nlohmann::json::array();
  double worst_delay_ms = 0;
  int bandwidth_met = 0;
  for (const sim::DlpfSetting& r : rows) {
    // a first-order low-pass at bandwidth B delays 1 / (2 pi B) at low frequency
    const bool widened = r.gyro_table.delay_s < 1.0 / (2 * std::numbers::pi * r.gyro_table.bandwidth_hz);
    const double delay_err = std::max(std::abs(r.gyro.delay_ms - r.gyro_table.delay_s * 1e3),
                                      std::abs(r.accel.delay_ms - r.accel_table.delay_s * 1e3));
    const bool bw_met = gyroBandwidthMet(r, widened);
    worst_delay_ms = std::max(worst_delay_ms, delay_err);
    bandwidth_met += bw_met;
    t.addRow({std::to_string(r.cfg), tableCell(r.gyro_table), modelCell(r.gyro),
              fmt::format("{:.3f} deg/s", r.gyro.noise_rms), tableCell(r.accel_table), modelCell(r.accel),
              fmt::format("{:.1f} mg", r.accel.noise_rms * 1e3),
              fmt::format("{}, {}", verdict(delay_err <= kDelayWithinMs), verdict(bw_met))});
    nlohmann::json gyro = measuredJson(r.gyro, r.gyro_table, 1.0);
    gyro["widened"] = widened;
    s.json["dlpf"].push_back(
        {{"cfg", r.cfg}, {"gyro", gyro}, {"accel", measuredJson(r.accel, r.accel_table, 1e3)}});
  }
  const sim::Mpu6050Params unit;
  t.addNote(fmt::format("table: the datasheet's (PS-MPU-6000A rev 3.4, CONFIG register), its one home "
                        "tools/sim/src/mpu6050.cpp; model: measured on the chip model at +-250 deg/s and +-4 g, as "
                        "`thrustcal sim imu` prints it: delay from a ramp, -3 dB from sines fitted at the sample "
                        "instants, noise rms at rest over {:g} s ({:g} deg/s/rtHz, {:g} ug/rtHz)",
                        sim::kDlpfNoiseSeconds, unit.gyro_noise_dps_per_rthz, unit.accel_noise_g_per_rthz * 1e6));
  t.addNote(fmt::format("met?: both delays within {} ms of the table's; the gyro's -3 dB within {:.0f} % of the "
                        "table's, or at or above it where the table's delay is shorter than a first-order low-pass "
                        "at its bandwidth (the model widens the low-pass to meet the delay)",
                        kDelayWithinMs, kGyroBandwidthWithinPct));
  s.tables.push_back(t);
  s.json["noise_seconds"] = sim::kDlpfNoiseSeconds;
  s.json["units"] = {{"gyro_noise_rms", "deg/s"}, {"accel_noise_rms", "mg"}};
  s.json["worst_delay_error_ms"] = worst_delay_ms;
  const int n = static_cast<int>(rows.size());
  s.targets.push_back(TargetCheck{"MPU-6050 model: DLPF delay against the datasheet's (gyro and accel, CFG 0-6)",
                                  fmt::format("worst {:.3f} ms off", worst_delay_ms),
                                  fmt::format("within {} ms", kDelayWithinMs), worst_delay_ms <= kDelayWithinMs});
  s.targets.push_back(TargetCheck{
      "MPU-6050 model: gyro -3 dB against the datasheet's bandwidth (CFG 0-6)",
      fmt::format("{} of {} settings", bandwidth_met, n),
      fmt::format("within {:.0f} %, or above where widened to meet the delay", kGyroBandwidthWithinPct),
      bandwidth_met == n});
  return s;
}

#endif

}  // namespace bench

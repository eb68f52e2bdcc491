// Power loss while gather_store writes a model v2 record, on the REAL images in simavr.
//
// (a) gather_store.elf on the plant bench (tools/plant, one varied KV1100 + 9x4.7 motor on
//     slot 0): cal, sweep on a full 3S LiPo, `store v2` (the old model, copy A), drain the pack
//     to 25 % charge, tare, sweep, `store v2` again (refines: the new model, copy B). Every
//     physical EEPROM byte write of that second store is recorded from the simulated CPU's
//     EECR (EEPE strobe: address EEAR, value EEDR), in order.
// (b) For EVERY cut point k = 0..N (N = writes of the second store) the EEPROM image "old image
//     + the first k writes" is what a power loss after write k leaves. read_run.elf boots on it
//     and must arm motor 0 and fly the old or the new model: its start-up line must be the old
//     or the new model's, and for two force commands the PWM it sends (status line and the
//     measured pulse on D6) must be tc::forceToPwmV2 of that same model at its filtered bus
//     voltage. The record's design also fixes WHEN it switches (the new copy becomes valid
//     with its last CRC byte), so cuts 0..N-1 must fly the old model and cut N the new one.
//
// read_run runs on a bare board: 0 mV on A0 and a constant battery on A1, so its bus filter
// settles to one value and the expected PWMs are exact (the reciprocal it keeps may be one LSB
// off 2^28 / mV: 1 us of tolerance). Budgets are simulated seconds; the bench part (two sweeps
// of 81 steps at 200 ms) is cached next to the test binary per gather_store build, because
// ctest runs every test in its own process.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "power_cut_support.hpp"

namespace {

using namespace power_cut;

// ---- tests -----------------------------------------------------------------------------------

class StoreV2PowerCut : public ::testing::TestWithParam<SecondStore> {};

TEST_P(StoreV2PowerCut, TheSecondStoreWritesOnlyTheSpareCopyBodyThenSequenceThenCrc) {
  HIL_REQUIRE_IMAGE("gather_store");
  // given / when: the recorded second store
  const StoreRecording& rec = recording(GetParam());
  ASSERT_FALSE(rec.writes.empty()) << "no EEPROM write observed on EECR: " << rec.second_store_line;
  // then: it wrote the new model into copy B and said how many bytes it wrote
  EXPECT_NE(rec.first_store_line.find("copy A, sequence 1): fitted from one sweep"),
            std::string::npos)
      << rec.first_store_line;
  EXPECT_NE(rec.second_store_line.find(GetParam() == SecondStore::kRefine
                                           ? "copy B, sequence 2): refined with this sweep"
                                           : "copy B, sequence 2): fitted from one sweep"),
            std::string::npos)
      << rec.second_store_line;
  EXPECT_EQ(rec.reported_bytes, static_cast<int>(rec.writes.size())) << rec.second_store_line;
  // replaying the writes on the old image gives exactly the final image
  EXPECT_EQ(cutImage(rec, rec.writes.size()), rec.final_image);
  // every write lies in copy B, each byte once, in the record's order: body, sequence, CRC
  const uint16_t base = tc::copyAddressV2(0, 1);
  auto phase = [&](uint16_t addr) {
    const uint16_t off = static_cast<uint16_t>(addr - base);
    if (off == tc::kRecordV2SeqOffset || off == tc::kRecordV2SeqOffset + 1) return 1;
    return off >= tc::kRecordV2CrcOffset ? 2 : 0;
  };
  std::vector<bool> seen(sim::kEepromBytes, false);
  int last_phase = 0;
  for (const auto& w : rec.writes) {
    ASSERT_GE(w.addr, base);
    ASSERT_LT(w.addr, base + tc::kRecordV2Bytes);
    EXPECT_FALSE(seen[w.addr]) << "byte " << w.addr << " written twice";
    seen[w.addr] = true;
    EXPECT_GE(phase(w.addr), last_phase) << "byte " << w.addr << " out of order";
    last_phase = phase(w.addr);
  }
  EXPECT_EQ(phase(rec.writes.back().addr), 2) << "the last write must be a CRC byte";
  RecordProperty("second_store_v2_bytes", std::to_string(rec.writes.size()));
  // storing again writes nothing: the firmware says so and the EECR saw no write
  EXPECT_EQ(rec.third_store_writes, 0) << rec.third_store_line;
  EXPECT_NE(rec.third_store_line.find(GetParam() == SecondStore::kRefine
                                          ? "error: motor 0 already holds a model v2 refined by a "
                                            "sweep at"
                                          : "motor 0 already holds this model v2 (copy B, sequence "
                                            "2): nothing to write; wrote 0 bytes"),
            std::string::npos)
      << rec.third_store_line;
  // and the stack of `store v2` (fit or refine, then the two-copy write) fits the SRAM left
  // by the static data with room to spare
  EXPECT_GE(rec.free_sram_bytes, 256) << "static " << rec.static_sram_bytes << " B, stack "
                                      << rec.peak_stack_bytes << " B";
  RecordProperty("static_sram_bytes", std::to_string(rec.static_sram_bytes));
  RecordProperty("store_v2_peak_stack_bytes", std::to_string(rec.peak_stack_bytes));
  RecordProperty("free_sram_bytes", std::to_string(rec.free_sram_bytes));
  std::printf("%s: second store v2 wrote %zu bytes; SRAM static %d B, peak stack %d B, never "
              "touched %d B\n",
              secondStoreName(GetParam()).c_str(), rec.writes.size(), rec.static_sram_bytes,
              rec.peak_stack_bytes, rec.free_sram_bytes);
  RecordProperty("bench_wall_s", fmt::format("{:.2f}", rec.wall_s));
}

TEST_P(StoreV2PowerCut, EveryCutLeavesReadRunArmedAndFlyingTheOldOrTheNewModel) {
  HIL_REQUIRE_IMAGE("gather_store");
  HIL_REQUIRE_IMAGE("read_run");
  // given: the old and the new model, as the codec decodes the images before and after
  const StoreRecording& rec = recording(GetParam());
  ASSERT_FALSE(rec.writes.empty());
  tc::ModelV2 old_model, new_model;
  ASSERT_EQ(readSlot0(rec.old_image, old_model).copy, 0);
  const tc::RecordV2Read after = readSlot0(rec.final_image, new_model);
  ASSERT_EQ(after.copy, 1);
  ASSERT_EQ(after.sequence, 2u);
  const std::string old_report = reportFor(old_model), new_report = reportFor(new_model);
  ASSERT_NE(old_report, new_report);
  // Two forces where the models' PWMs differ most at read_run's bus voltage (measured on the
  // k = 0 boot). After a motor swap they differ by several us, so each PWM also tells the
  // models apart; a refine moves the PWMs by about 1 us only (the one-sweep model is already
  // close on this plant), there the start-up line tells them apart and the PWM check shows
  // that the model read_run reports is the one it flies.
  const BootResult probe = bootAndFly(rec.old_image, {100});
  ASSERT_EQ(probe.flown.size(), 1u);
  ASSERT_GT(probe.flown[0].bus_mv, 6000) << "no status line for motor 0";
  const uint16_t bus_mv = static_cast<uint16_t>(probe.flown[0].bus_mv);
  std::vector<std::pair<int, int>> by_gap;  // (|old - new| us, grams)
  for (int g = 50; g <= 400; g += 25)
    by_gap.push_back({std::abs(expectedPwm(old_model, g, bus_mv) - expectedPwm(new_model, g, bus_mv)), g});
  std::sort(by_gap.rbegin(), by_gap.rend());
  if (GetParam() == SecondStore::kMotorSwap) {
    ASSERT_GE(by_gap[1].first, 3) << "old and new model fly within 2 us of each other: the PWM "
                                     "check could not tell them apart";
  }
  RecordProperty("old_new_pwm_gap_us", std::to_string(by_gap[0].first));
  const std::vector<int> forces = {by_gap[0].second, by_gap[1].second};

  // when / then: every cut point
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = rec.writes.size();
  std::size_t flew_new = 0;
  double simulated_s = 0;
  bool seen_new = false;
  for (std::size_t k = 0; k <= n; ++k) {
    SCOPED_TRACE(fmt::format("cut after {} of {} writes", k, n));
    const BootResult b = bootAndFly(cutImage(rec, k), forces);
    simulated_s += b.simulated_s;
    // start-up report: motor 0 armed with one of the two models; the others not calibrated
    std::string line;
    for (const auto& l : b.report)
      if (l.rfind("motor 0:", 0) == 0) line = l;
    const bool is_old = line.rfind(old_report, 0) == 0;
    const bool is_new = line.rfind(new_report, 0) == 0;
    ASSERT_TRUE(is_old || is_new) << "read_run said: '" << line << "'\nold: '" << old_report
                                  << "'\nnew: '" << new_report << "'";
    const std::string tail = line.substr((is_new ? new_report : old_report).size());
    // a half-written spare copy may be reported, never anything else
    EXPECT_TRUE(tail.empty() || tc::test::Pattern("; warning: copy B .*, flying copy A - recalibrate to "
                                                  "restore the spare copy").matches(tail))
        << line;
    EXPECT_NE(std::find(b.report.begin(), b.report.end(), "calibrated motors: 1 of 4"),
              b.report.end());
    const tc::ModelV2& flown_model = is_new ? new_model : old_model;
    // the PWMs it sends are that model's
    ASSERT_EQ(b.flown.size(), forces.size());
    for (const auto& f : b.flown) {
      ASSERT_GT(f.pwm_us, 0) << "no status line after f 0 " << f.grams;
      const int expected = expectedPwm(flown_model, f.grams, static_cast<uint16_t>(f.bus_mv));
      EXPECT_NEAR(f.pwm_us, expected, 1) << f.grams << " g";
      EXPECT_NEAR(f.pulse_us, f.pwm_us + 0.5, 1.0) << f.grams << " g on D6";
    }
    // the switch happens once, with the last CRC byte
    if (is_new) ++flew_new;
    EXPECT_FALSE(seen_new && is_old) << "went back to the old model";
    seen_new = seen_new || is_new;
    EXPECT_EQ(is_new, k == n);
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(flew_new, 1u);
  RecordProperty("cut_points", std::to_string(n + 1));
  RecordProperty("cuts_wall_s", fmt::format("{:.2f}", wall_s));
  RecordProperty("cuts_simulated_s", fmt::format("{:.1f}", simulated_s));
  std::printf("%s: %zu cut points booted in %.2f s wall (%.1f s simulated), old/new PWM gap "
              "up to %d us\n",
              secondStoreName(GetParam()).c_str(), n + 1, wall_s, simulated_s, by_gap[0].first);
}

INSTANTIATE_TEST_SUITE_P(SecondStore, StoreV2PowerCut,
                         ::testing::Values(SecondStore::kRefine, SecondStore::kMotorSwap),
                         [](const ::testing::TestParamInfo<SecondStore>& info) {
                           return secondStoreName(info.param);
                         });

// ---- v1 -> v2: `store v2` over a thesis record -------------------------------------------------
}  // namespace

// Issue 8, item 6 (docs/safety.md): stack headroom. The boot code paints the SRAM above the
// static data; `status` reports how much of it was never touched. Each image runs its deepest
// paths, then `status`: at least 512 bytes must be left. The harness also scans the SRAM itself
// (the paint byte 0xC5 upwards from the linker's _end) as a check on the firmware's figure.
#include <gtest/gtest.h>

#include <regex>

#include "safety_support.hpp"
#include "sim/elf_symbols.hpp"
#include "sim/rigs.hpp"

extern "C" {
#include <simavr/sim_avr.h>
}

namespace {

constexpr int kHeadroomRequired = 512;

struct Headroom {
  int untouched = -1, size = -1;
};

Headroom fromStatus(const std::vector<std::string>& lines) {
  static const std::regex re(R"(stack: (\d+) of (\d+) bytes never used)");
  Headroom h;
  for (const auto& l : lines) {
    std::smatch m;
    if (std::regex_search(l, m, re)) {
      h.untouched = std::stoi(m[1]);
      h.size = std::stoi(m[2]);
    }
  }
  return h;
}

// Paint bytes still intact from _end upwards, read from the simulated SRAM.
int scanUntouched(sim::Board& board, const std::string& elf) {
  const uint32_t end = sim::elfSymbol(elf, "_end").address & 0xFFFF;
  const avr_t* avr = board.avr();
  int n = 0;
  for (uint32_t a = end; a <= avr->ramend && avr->data[a] == 0xC5; ++a) ++n;
  return n;
}

std::string flood(std::size_t bytes) {
  std::string f;
  while (f.size() < bytes) f += "a\b";
  return f;
}

TEST(StackHeadroom, GatherStoreKeepsAtLeast512BytesAfterItsDeepestPaths) {
  HIL_REQUIRE_IMAGE("gather_store");
  // given: a calibration on the plant bench to store v2 from
  plant::BenchParams params = plant::BenchParams::thesis("kv1100_9x4.7");
  params.actuator = sim::motorForSeed("kv1100_9x4.7", 13, 0.03);
  sim::BenchRig rig(hil::imagePath("gather_store"), params, 0);
  sim::Console con(rig.board, "gs> ");
  con.waitPrompt(10.0);
  con.command(fmt::format("cal {}", static_cast<int>(std::lround(params.actuator.mountWeight_g()))), 10);
  con.command("range 1040 1800");
  con.command("settle 60");
  // when: sweep, store v2 (the fit: the deepest), show, store 1, help under a flood, status
  con.command("sweep", 120);
  const auto stored = con.command("store v2", 10);
  con.command("show", 10);
  con.command("store 1", 10);
  rig.board.sendText("help\r" + flood(3000));
  safety::drain(con);
  const auto status = con.command("status", 10);
  // then
  ASSERT_TRUE(safety::contains(::testing::PrintToString(stored), "stored model v2")) << con.tail();
  const Headroom h = fromStatus(status);
  ASSERT_GT(h.size, 0) << ::testing::PrintToString(status);
  const int scanned = scanUntouched(rig.board, hil::imagePath("gather_store"));
  RecordProperty("gather_store_stack_untouched", h.untouched);
  std::printf("gather_store: %d of %d stack bytes never used (harness scan %d)\n", h.untouched,
              h.size, scanned);
  EXPECT_GE(h.untouched, kHeadroomRequired);
  EXPECT_LE(scanned, h.untouched) << "status itself may only use more";
  EXPECT_GE(scanned, h.untouched - 64);
}

TEST(StackHeadroom, ReadRunKeepsAtLeast512BytesAfterItsDeepestPaths) {
  HIL_REQUIRE_IMAGE("read_run");
  // given: two v1 and two v2 slots (the boot decodes both v2 copies: the deepest start-up)
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  // when: a lift-off, then help under a flood with the motors running (its wait hook runs the
  // frames on top of the reply), then status
  rr.con.send("liftoff 250 300 500");
  rr.keepAliveFor(1.2);
  rr.con.command("f 200");
  rr.board.sendText("help\r" + flood(2000));
  safety::drain(rr.con, 0.1);
  const auto status = rr.con.command("status");
  // then
  const Headroom h = fromStatus(status);
  ASSERT_GT(h.size, 0) << ::testing::PrintToString(status) << rr.con.tail(40);
  const int scanned = scanUntouched(rr.board, hil::imagePath("read_run"));
  RecordProperty("read_run_stack_untouched", h.untouched);
  std::printf("read_run: %d of %d stack bytes never used (harness scan %d)\n", h.untouched, h.size,
              scanned);
  EXPECT_GE(h.untouched, kHeadroomRequired);
  EXPECT_LE(scanned, h.untouched);
  EXPECT_GE(scanned, h.untouched - 64);
}

}  // namespace

// Issue 8, item 6 (docs/safety.md): stack headroom. The boot code paints the SRAM above the
// static data; `status` reports how much of it was never touched. Each image runs its deepest
// paths (sim/stack_scenario.hpp, the scenario `thrustcal bench footprint` reports too), then
// `status`: at least 512 bytes must be left. The harness also scans the SRAM itself (the paint
// byte upwards from the linker's _end) as a check on the firmware's figure.
#include <gtest/gtest.h>

#include <cstdio>

#include "safety_support.hpp"
#include "sim/stack_scenario.hpp"

namespace {

constexpr int kHeadroomRequired = 512;

TEST(StackHeadroom, GatherStoreKeepsAtLeast512BytesAfterItsDeepestPaths) {
  HIL_REQUIRE_IMAGE("gather_store");
  // given: a calibration on the plant bench to store v2 from
  // when: sweep, store v2 (the fit: the deepest), show, store 1, help under a flood, status
  const sim::StackHeadroom h = sim::gatherStoreDeepestPaths(hil::imagePath("gather_store"));
  // then
  ASSERT_TRUE(safety::contains(::testing::PrintToString(h.deepest), "stored model v2")) << h.console_tail;
  ASSERT_GT(h.stack_bytes, 0) << ::testing::PrintToString(h.status);
  RecordProperty("gather_store_stack_untouched", h.untouched_bytes);
  std::printf("gather_store: %d of %d stack bytes never used (harness scan %d)\n", h.untouched_bytes,
              h.stack_bytes, h.scanned_untouched_bytes);
  EXPECT_GE(h.untouched_bytes, kHeadroomRequired);
  EXPECT_LE(h.scanned_untouched_bytes, h.untouched_bytes) << "status itself may only use more";
  EXPECT_GE(h.scanned_untouched_bytes, h.untouched_bytes - 64);
}

TEST(StackHeadroom, ReadRunKeepsAtLeast512BytesAfterItsDeepestPaths) {
  HIL_REQUIRE_IMAGE("read_run");
  // given: two v1 and two v2 slots (the boot decodes both v2 copies: the deepest start-up)
  // when: a lift-off, then help under a flood with the motors running (its wait hook runs the
  // frames on top of the reply), then status
  const sim::StackHeadroom h = sim::readRunDeepestPaths(hil::imagePath("read_run"));
  // then
  ASSERT_GT(h.stack_bytes, 0) << ::testing::PrintToString(h.status) << h.console_tail;
  RecordProperty("read_run_stack_untouched", h.untouched_bytes);
  std::printf("read_run: %d of %d stack bytes never used (harness scan %d)\n", h.untouched_bytes,
              h.stack_bytes, h.scanned_untouched_bytes);
  EXPECT_GE(h.untouched_bytes, kHeadroomRequired);
  EXPECT_LE(h.scanned_untouched_bytes, h.untouched_bytes);
  EXPECT_GE(h.scanned_untouched_bytes, h.untouched_bytes - 64);
}

}  // namespace

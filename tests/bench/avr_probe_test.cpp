// The AVR probe behind `thrustcal bench compute|footprint` runs to the end in simavr, fits
// every model, and measures what it claims (structure, not speed).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "bench/avr_probe.hpp"

TEST(BenchAvrProbe, RunsToTheEndWithEveryFitSucceedingAndEverySectionMeasured) {
  const std::string elf = bench::builtinProbePath();
  if (elf.empty() || !std::filesystem::exists(elf)) GTEST_SKIP() << "avr-g++ missing: no AVR probe built";
  // when
  const bench::ProbeResult r = bench::runProbe(elf);
  // then: no fit failed, every section ran its frames, and the assembly frame agreed with the
  // portable one on every frame it was checked against
  ASSERT_EQ(r.values.count(0x83), 1u);
  EXPECT_EQ(r.values.at(0x83), 0u);
  ASSERT_EQ(r.values.count(0x89), 1u);
  EXPECT_EQ(r.values.at(0x89), 0u);
  EXPECT_GT(r.values.at(0x8A), 0u);
  for (int label : {1, 2, 3, 4, 5}) {
    SCOPED_TRACE(label);
    ASSERT_EQ(r.sections.count(label), 1u);
    EXPECT_EQ(r.sections.at(label).count, r.values.at(0x84));
    EXPECT_LE(r.sections.at(label).min, r.sections.at(label).mean);
    EXPECT_LE(r.sections.at(label).mean, r.sections.at(label).max);
  }
  // and: a slot holds either model's run-time form, so it is at least as big as the bigger one
  const uint16_t v2 = r.values.at(0x85), v1 = r.values.at(0x86), slot = r.values.at(0x82);
  EXPECT_GT(v2, 0u);
  EXPECT_GT(v1, 0u);
  EXPECT_GE(slot, std::max(v1, v2));
  EXPECT_LE(4 * slot, 1024);
}

TEST(BenchAvrProbe, ReportsAnImageThatCannotBeRead) {
  EXPECT_THROW(bench::runProbe("/nonexistent/probe.elf"), std::runtime_error);
}

#include <gtest/gtest.h>

#include <sstream>

#include "bench/table.hpp"

TEST(BenchTable, AlignsColumnsAndPadsShortRows) {
  // given
  bench::Table t("title", {"model", "RMS %", "target", "met?"});
  t.addRow({"v2", "0.25", "<= 1", bench::verdict(true)});
  t.addRow({"a much longer name", "18.21"});
  // when
  std::istringstream lines(t.str());
  std::string title, header, rule, r1, r2;
  std::getline(lines, title);
  std::getline(lines, header);
  std::getline(lines, rule);
  std::getline(lines, r1);
  std::getline(lines, r2);
  // then: figures are right-aligned under their header
  EXPECT_EQ(header.find("RMS %") + 5, r1.find("0.25") + 4);
  EXPECT_EQ(header.find("RMS %") + 5, r2.find("18.21") + 5);
  EXPECT_NE(r1.find("yes"), std::string::npos);
  EXPECT_EQ(bench::verdict(false), "NO");
}

// The manual's command list is gather_store's `help`, which the command table prints
// (firmware/gather_store/gather_store_commands.cpp): these tests run `help` on the fake HAL and
// compare it with the blocks in docs/gather_store.md and docs/console.md, so a command added,
// renamed or given another range in the table fails here until the docs say the same.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "gather_store_fixture.hpp"

namespace {

using gs_test::GatherStore;

std::string readDoc(const char* relative) {
  std::ifstream in(std::string(THRUSTCAL_SOURCE_DIR) + "/" + relative);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The fenced block (``` ... ```) that starts right after the first line holding `marker`; "" if
// there is none.
std::string blockAfter(const std::string& doc, const std::string& marker) {
  const size_t at = doc.find(marker);
  if (at == std::string::npos) return "";
  const size_t open = doc.find("```\n", at);
  if (open == std::string::npos) return "";
  const size_t begin = open + 4;
  const size_t close = doc.find("```", begin);
  if (close == std::string::npos) return "";
  return doc.substr(begin, close - begin);
}

class GatherStoreDocs : public GatherStore {
 protected:
  // `help`'s reply as the docs show it: lines joined with '\n', no echo, no prompt.
  std::string helpText() {
    std::string text;
    for (const std::string& line : responseLines(run("help"))) text += line + "\n";
    return text;
  }
};

TEST_F(GatherStoreDocs, TheManualsCommandListIsTheHelpTheTablePrints) {
  const std::string doc = readDoc("docs/gather_store.md");
  ASSERT_FALSE(doc.empty()) << "docs/gather_store.md not found under " << THRUSTCAL_SOURCE_DIR;
  EXPECT_EQ(blockAfter(doc, "<!-- gather_store help -->"), helpText())
      << "docs/gather_store.md: paste the block above (the output of `help`) after the "
         "<!-- gather_store help --> marker";
}

TEST_F(GatherStoreDocs, TheConsolePagesHelpSessionIsTheHelpTheTablePrints) {
  const std::string doc = readDoc("docs/console.md");
  ASSERT_FALSE(doc.empty()) << "docs/console.md not found under " << THRUSTCAL_SOURCE_DIR;
  EXPECT_EQ(blockAfter(doc, "<!-- gather_store help -->"), "gs> help\n" + helpText() + "gs> \n")
      << "docs/console.md: the gather_store help session after <!-- gather_store help -->";
}

}  // namespace

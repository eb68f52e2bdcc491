// Shared by the gather_store host tests: the fake EEPROM as codec Storage, output helpers and
// the fixture (fake HAL + plant.hpp + the app, one command line at a time).
#pragma once
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "gather_store_app.hpp"
#include "hal/fake.hpp"
#include "hal/hal.hpp"
#include "plant.hpp"

namespace gs_test {

// The EEPROM seen through the codec's Storage interface, for decoding what was stored.
struct FakeStorage {
  static uint8_t readByte(uint16_t addr) { return hal::fake::eeprom()[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) { hal::fake::eeprom()[addr] = value; }
};

inline std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::string line;
  for (char c : text) {
    if (c == '\n') {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      lines.push_back(line);
      line.clear();
    } else {
      line.push_back(c);
    }
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

inline bool startsWith(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

inline int countLinesStartingWith(const std::string& text, const char* prefix) {
  int n = 0;
  for (const auto& line : splitLines(text)) n += startsWith(line, prefix) ? 1 : 0;
  return n;
}

class GatherStore : public ::testing::Test {
 protected:
  void SetUp() override {
    hal::fake::reset();
    hal::Esc::init();
    plant_.attach();
    app_ = std::make_unique<gs::GatherStoreApp>();
    app_->begin();
    banner_ = hal::fake::takeOutput();
  }
  void TearDown() override { hal::fake::reset(); }

  // Types `line` + CR and lets the app handle it; returns everything printed meanwhile
  // (echo, response, next prompt).
  std::string run(const std::string& line) {
    hal::fake::takeOutput();
    hal::fake::feedInput(line + "\r");
    hal::fake::setTimeLimitMs(hal::fake::nowMs() + 600000);  // no command may hang
    while (!app_->poll()) hal::Clock::sleepUntilInterrupt();
    hal::fake::setTimeLimitMs(0);
    return hal::fake::takeOutput();
  }

  // The response without the echoed command line and the trailing prompt.
  static std::vector<std::string> responseLines(const std::string& out) {
    std::vector<std::string> lines = splitLines(out);
    if (!lines.empty()) lines.erase(lines.begin());                       // echo
    if (!lines.empty() && lines.back() == "gs> ") lines.pop_back();       // prompt
    return lines;
  }

  void calibrateAndTare() {
    ASSERT_NE(run("cal 95").find("calibrated"), std::string::npos);
  }

  std::string sweep() { return run("sweep"); }

  std::vector<uint8_t> eepromSnapshot() const {
    return std::vector<uint8_t>(hal::fake::eeprom(), hal::fake::eeprom() + hal::Eeprom::kSize);
  }

  gs_test::Plant plant_;
  std::unique_ptr<gs::GatherStoreApp> app_;
  std::string banner_;
};

}  // namespace gs_test

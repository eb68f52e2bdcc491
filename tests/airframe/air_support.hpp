// Shared by the airframe tests: the air_probe image on a board with the MPU-6050 on its TWI.
#pragma once
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/imu_on_board.hpp"

namespace air {

// Runs a shell command; its stdout and stderr, and its exit status in `status`.
inline std::string shell(const std::string& command, int& status) {
  std::string out;
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  char buf[512];
  while (p && std::fgets(buf, sizeof buf, p)) out += buf;
  status = p ? ::pclose(p) : -1;
  return out;
}

// A perfect IMU (no unit errors, no noise) unless a test asks otherwise.
inline sim::Mpu6050Params idealImu() {
  sim::Mpu6050Params p;
  p.unit_errors = false;
  p.noise = false;
  return p;
}

class TwiProbe : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string(AIR_PROBE_ELF).empty()) GTEST_SKIP() << "avr-gcc not found: no air_probe image";
    board = std::make_unique<sim::Board>(AIR_PROBE_ELF);
    imu = std::make_unique<sim::ImuOnBoard>(*board, idealImu(), sim::levelAtRest());
    console = std::make_unique<sim::Console>(*board, "a> ");
    console->waitPrompt(0.1);
  }
  void TearDown() override {
    console.reset();
    imu.reset();
    board.reset();
  }
  std::vector<std::string> command(const std::string& line, double budget_s = 0.5) {
    return console->command(line, budget_s);
  }
  // PWR_MGMT_1 = 0: the IMU leaves sleep.
  void wake() { command("wr 107 0"); }

  std::unique_ptr<sim::Board> board;
  std::unique_ptr<sim::ImuOnBoard> imu;
  std::unique_ptr<sim::Console> console;
};

}  // namespace air

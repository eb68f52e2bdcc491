// Power loss while fly writes its saved parameters (`param save`), on the REAL image in simavr.
//
// fly.elf boots on a bare board (no IMU: the console works, arming does not), saves one set of
// parameters (sequence 1, copy A), changes some and saves again (sequence 2, copy B). Every
// physical EEPROM byte write of that second save is recorded from the simulated CPU's EECR
// (EEPE strobe: address EEAR, value EEDR). For EVERY cut point k = 0..N the image "before the
// second save + its first k writes" is what a power loss after write k leaves: fly boots on it
// (a power-on reset of the same board) and must say it loaded sequence 1 or 2 and list exactly
// the first or the second set, never a mix: sequence 1 for k < N (the new copy becomes valid
// with its last CRC byte, the last write), sequence 2 for k = N.
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "eeprom_write_recorder.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"

namespace {

std::string flyImage() {
  const char* env = std::getenv("THRUSTCAL_AVR_BUILD_DIR");
  return std::string(env && *env ? env : THRUSTCAL_AVR_BUILD_DIR) + "/firmware/fly/fly.elf";
}

using hil_power::EepromWrite;
using hil_power::EepromWriteRecorder;

std::vector<std::string> mustCommand(sim::Console& con, const std::string& line) {
  auto lines = con.command(line, 5.0);
  for (const auto& l : lines)
    if (l.rfind("error:", 0) == 0) throw std::runtime_error(fmt::format("fly refused \"{}\": {}", line, l));
  return lines;
}

std::string paramsLine(const std::vector<std::string>& lines) {
  for (const auto& l : lines)
    if (l.rfind("params: ", 0) == 0) return l;
  return "(no params line)";
}

// `param list` without the "unsaved" notes: the values as they fly.
std::vector<std::string> values(sim::Console& con) {
  std::vector<std::string> out;
  for (std::string l : mustCommand(con, "param list")) {
    const std::size_t note = l.find("; unsaved");
    out.push_back(note == std::string::npos ? l : l.substr(0, note));
  }
  return out;
}

TEST(ParamSavePowerCut, EveryCutLeavesTheOldOrTheNewParametersWholeAndTheNewWinWithTheLastByte) {
  if (!std::filesystem::exists(flyImage())) GTEST_SKIP() << "no AVR image " << flyImage() << ": build the AVR tree";
  // given: fly booted, a first set saved
  sim::Board board(flyImage());
  sim::Console con(board, "fly> ");
  EXPECT_EQ(paramsLine(con.waitPrompt(5.0)), "params: none saved: the defaults (param set NAME VALUE, then param save)");
  for (const char* l : {"param set angle_kp 900", "param set layout plus", "param set yaw_arm_um 15100"}) mustCommand(con, l);
  EXPECT_NE(mustCommand(con, "param save")[0].find("param: saved 34 parameters (motor 3's slot, copy A, sequence 1)"),
            std::string::npos);
  const std::vector<std::string> old_values = values(con);
  const std::vector<uint8_t> before = board.eeprom();
  // when: a second set is saved, its byte writes recorded
  for (const char* l : {"param set angle_kp 1200", "param set level_x_mg -12.5", "param set ap_expo 0.7000",
                        "param set mode pwm", "param set hover_us 1480", "param set crash_deg 30"})
    mustCommand(con, l);
  EepromWriteRecorder recorder(board);
  recorder.recording = true;
  const std::string saved = mustCommand(con, "param save")[0];
  recorder.recording = false;
  EXPECT_NE(saved.find("copy B, sequence 2"), std::string::npos) << saved;
  const std::vector<std::string> new_values = values(con);
  const std::vector<EepromWrite> writes = recorder.writes;
  ASSERT_GT(writes.size(), 8u);
  for (const EepromWrite& w : writes) {
    EXPECT_GE(w.addr, 3 * 1024 + 768) << "only copy B of motor 3's slot is written";
    EXPECT_LT(w.addr, 3 * 1024 + 896);
  }
  // then: fly boots on the image cut after every write
  int olds = 0;
  for (std::size_t k = 0; k <= writes.size(); ++k) {
    SCOPED_TRACE(fmt::format("cut after {} of {} writes", k, writes.size()));
    std::vector<uint8_t> image = before;
    for (std::size_t i = 0; i < k; ++i) image[writes[i].addr] = writes[i].value;
    board.setEeprom(image);
    board.reset(sim::ResetKind::kPowerOn);
    const std::string line = paramsLine(con.waitPrompt(5.0));
    const bool is_new = k == writes.size();
    EXPECT_EQ(line, is_new ? "params: 34 loaded from the EEPROM (motor 3's slot, copy B, sequence 2)"
                           : "params: 34 loaded from the EEPROM (motor 3's slot, copy A, sequence 1)");
    EXPECT_EQ(values(con), is_new ? new_values : old_values);
    olds += !is_new;
  }
  EXPECT_EQ(olds, static_cast<int>(writes.size()));
  std::cout << "[ figures ] param save: " << writes.size() << " byte writes, " << writes.size() + 1
            << " boots; simulated " << board.simulatedSeconds() << " s, wall " << board.wallSeconds() << " s\n";
}

}  // namespace

// docs/board.md's story, run as a user runs it: a stock Mega2560 (`thrustcal sim board`, the
// bootloader alone) and nothing but `thrustcal board ...` commands, each a separate process on
// the board's port: flash gather_store, calibrate a motor, read the EEPROM, put it back with
// the calibrated slot in all four slots, flash read_run, fly the lift-off, read the EEPROM again.
#include <gtest/gtest.h>

#include <csignal>
#include <fstream>
#include <sstream>

#include "board_support.hpp"
#include "hex/intel_hex.hpp"
#include "sim/scenarios.hpp"

namespace {

using board_test::image;
using board_test::slurp;


int countLines(const std::string& text, const std::string& prefix) {
  int n = 0;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) n += l.rfind(prefix, 0) == 0;
  return n;
}

TEST(BoardStory, FromAStockBoardToACalibratedLiftoffWithThrustcalBoardOnly) {
  BOARD_REQUIRE_TOOLS();
  const std::string dir = board_test::tempDir("story");
  const std::string tc = THRUSTCAL_EXE;
  const std::string port = dir + "/ttyMega";
  const std::string eeprom_file = dir + "/board_eeprom.hex";
  // given: a board with only its bootloader, on a pty behind a stable link
  board_test::Process sim({tc, "sim", "board", "--link", port, "--eeprom", eeprom_file, "--slot",
                           "0", "--seeds", "11,12,13,14"});
  for (int i = 0; i < 100 && !std::filesystem::exists(port); ++i) sim.pump(0.1);
  ASSERT_TRUE(std::filesystem::exists(port)) << sim.output();
  auto step = [&](const std::vector<std::string>& args, double timeout_s) {
    std::vector<std::string> full = {tc, "board"};
    full.insert(full.end(), args.begin(), args.end());
    const board_test::ProcessResult r = board_test::run(full, timeout_s);
    std::cout << "[ figures ] thrustcal board " << args[0] << (args.size() > 1 ? " " + args[1] : "")
              << ": " << r.wall_s << " s\n";
    return r;
  };

  // when: flash gather_store through the bootloader
  auto r = step({"flash", "--port", port, image("gather_store", ".hex")}, 240);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("gather_store answers"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("verify included"), std::string::npos) << r.output;

  // calibrate motor 0 (seed 11 on the bench): one sweep, store 1, show, the lab's diagnosis
  r = step({"calibrate", "--port", port, "--slot", "0", "--mount-g", "81", "--yes", "--out-dir", dir,
            "--json", dir + "/cal.json"},
           240);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("stored curve 1 of motor 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("lab: model thesis"), std::string::npos) << r.output;
  const std::string sweep_csv = slurp(dir + "/calibrate_slot0_sweep1.csv");
  EXPECT_EQ(countLines(sweep_csv, "pwm_us,force_g,vbat_v,t_s,motor,dir"), 1);
  EXPECT_EQ(countLines(sweep_csv, "1"), 77) << "1040..1800 us in 10 us steps";

  // read the EEPROM through gather_store; the slot holds the curve
  r = step({"eeprom", "get", "--port", port, "-o", dir + "/after_cal.hex"}, 120);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::vector<uint8_t> ee = hex::readIntelHexFile(dir + "/after_cal.hex", 4096);
  tc::MotorCalibration cal;
  ASSERT_EQ(sim::decodeSlot(ee, 0, cal), "ok");

  // the calibrated slot in all four slots, written back (one motor's curve on four motors)
  for (int s = 1; s < 4; ++s) sim::copySlot(ee, 0, s);
  hex::writeIntelHexFile(dir + "/four.hex", ee);
  r = step({"eeprom", "put", "--port", port, dir + "/four.hex"}, 240);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("verified through gather_store"), std::string::npos) << r.output;

  // flash read_run and fly
  r = step({"flash", "--port", port, image("read_run", ".hex")}, 240);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("read_run answers"), std::string::npos) << r.output;
  r = step({"liftoff", "--port", port, "--force", "250", "--ramp-ms", "1000", "--hold-ms", "2000",
            "--yes", "-o", dir + "/liftoff.csv"},
           240);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string log = slurp(dir + "/liftoff.csv");
  EXPECT_EQ(countLines(log, "t_s,motor0_pwm_us"), 1) << log.substr(0, 500);
  EXPECT_GE(countLines(log, "# liftoff done"), 1) << log.substr(log.size() > 800 ? log.size() - 800 : 0);
  int rows = 0;
  {
    std::istringstream in(log);
    for (std::string l; std::getline(in, l);)
      rows += !l.empty() && std::isdigit(static_cast<unsigned char>(l[0]));
  }
  EXPECT_GE(rows, 25) << "3 s of lift-off streamed at 10 rows/s";

  // the EEPROM read through read_run is what was put
  r = step({"eeprom", "get", "--port", port, "-o", dir + "/final.hex"}, 120);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(hex::readIntelHexFile(dir + "/final.hex", 4096), ee);

  // the simulated board ends on Ctrl-C and saves its EEPROM
  sim.signal(SIGINT);
  const board_test::ProcessResult end = sim.wait(20);
  EXPECT_EQ(end.exit_code, 0) << end.output;
  EXPECT_EQ(hex::readIntelHexFile(eeprom_file, 4096), ee);
  EXPECT_NE(end.output.find("plant = the tethered quad"), std::string::npos) << end.output;
}

TEST(BoardStory, CommandsSayWhatIsWrongWhenThePortIsMissing) {
  const std::string tc = THRUSTCAL_EXE;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"flash", "--port", "/dev/nonexistent_tty", "x.hex"},
        std::vector<std::string>{"eeprom", "get", "--port", "/dev/nonexistent_tty", "-o", "/tmp/x"},
        std::vector<std::string>{"calibrate", "--port", "/dev/nonexistent_tty", "--slot", "0",
                                 "--mount-g", "81", "--yes"},
        std::vector<std::string>{"liftoff", "--port", "/dev/nonexistent_tty", "--force", "100",
                                 "--yes"},
        std::vector<std::string>{"params", "pull", "--port", "/dev/nonexistent_tty", "/tmp/x"},
        std::vector<std::string>{"params", "push", "--port", "/dev/nonexistent_tty", "/tmp/x"}}) {
    std::vector<std::string> full = {tc, "board"};
    full.insert(full.end(), args.begin(), args.end());
    const board_test::ProcessResult r = board_test::run(full, 30);
    SCOPED_TRACE(args[0]);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find("/dev/nonexistent_tty: no such serial port"), std::string::npos)
        << r.output;
  }
}

}  // namespace

// The board client's pure parts: the console checksum, the EEPROM CRC line, the sweep CSV.
#include <gtest/gtest.h>

#include <vector>

#include "board/calibrate.hpp"
#include "board/console_client.hpp"
#include "board/transfer.hpp"
#include "thrustcal/crc16.hpp"

namespace {

struct ChecksumCase {
  const char* line;
  const char* hex;
};

class Checksum : public ::testing::TestWithParam<ChecksumCase> {};

TEST_P(Checksum, IsTheXorOfTheLineInTwoUpperCaseHexDigits) {
  EXPECT_EQ(board::checksumHex(GetParam().line), GetParam().hex);
  EXPECT_EQ(board::withChecksum(GetParam().line), std::string(GetParam().line) + "*" + GetParam().hex);
}

// NMEA 0183's own example (without '$'), and lines worked out by hand.
INSTANTIATE_TEST_SUITE_P(
    Table, Checksum,
    ::testing::Values(ChecksumCase{"GPGLL,5300.97914,N,00259.98174,E,125926,A", "28"},
                      ChecksumCase{"", "00"}, ChecksumCase{"a", "61"},
                      ChecksumCase{"f 1 37", "53"},  // 66^20^31^20^33^37
                      ChecksumCase{"strict on", "2A"}));

TEST(EepromCrcs, LineRoundTripsAndMatchesTheCoreCrcOfEachSlot) {
  std::vector<uint8_t> img(4096);
  for (std::size_t i = 0; i < img.size(); ++i) img[i] = static_cast<uint8_t>(i * 13);
  const board::EepromCrcs c = board::EepromCrcs::of(img);
  EXPECT_EQ(c.slot[3], tc::crc16CcittFalse(img.data() + 3072, 1024));
  EXPECT_EQ(c.all, tc::crc16CcittFalse(img.data(), 4096));
  board::EepromCrcs parsed;
  ASSERT_TRUE(board::EepromCrcs::parse(c.text(), parsed));
  EXPECT_EQ(parsed, c);
}

TEST(EepromCrcs, AnythingButTheWholeLineIsNotParsed) {
  board::EepromCrcs c;
  EXPECT_FALSE(board::EepromCrcs::parse("eeprom crc slot0 77EB slot1 77EB", c));
  EXPECT_FALSE(board::EepromCrcs::parse("error: usage: eeprom crc|dump; nothing changed", c));
  EXPECT_FALSE(board::EepromCrcs::parse(
      "eeprom crc slot0 77EB slot1 77EB slot2 77EB slot3 77EB all 0FE1 extra", c));
  EXPECT_TRUE(board::EepromCrcs::parse(
      "eeprom crc slot0 77EB slot1 77eb slot2 77EB slot3 77EB all 0FE1", c));
}

TEST(SweepLog, CsvKeepsHeaderRowsAndCommentsInOrderAndCommentsOtherLines) {
  board::SweepLog log;
  log.lines = {"# sweep motor 0: 1040..1060 us", "pwm_us,force_g,vbat_v,t_s,motor,dir",
               "1040,0.0,12.600,0.500,0,1", "warning: something", "1050,1.2,12.590,1.000,0,1",
               "# done: 2 samples"};
  log.header = log.lines[1];
  log.rows = {log.lines[2], log.lines[4]};
  EXPECT_EQ(log.csv("first"),
            "# first\n# sweep motor 0: 1040..1060 us\npwm_us,force_g,vbat_v,t_s,motor,dir\n"
            "1040,0.0,12.600,0.500,0,1\n# warning: something\n1050,1.2,12.590,1.000,0,1\n"
            "# done: 2 samples\n");
}

}  // namespace

// ---- the console client against a scripted firmware on a pty ---------------------------------

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <functional>
#include <mutex>
#include <thread>

namespace {

// A firmware stand-in on the master side of a pty: echoes each line, answers it with
// `answer(line)`, prints the prompt. Lines arrive as the client sent them (checksum included).
class FakeFirmware {
 public:
  using Answer = std::function<std::string(const std::string& line)>;
  FakeFirmware(std::string prompt, Answer answer) : prompt_(std::move(prompt)), answer_(std::move(answer)) {
    master_ = ::posix_openpt(O_RDWR | O_NOCTTY);
    ::grantpt(master_);
    ::unlockpt(master_);
    path_ = ::ptsname(master_);
    ::fcntl(master_, F_SETFL, O_NONBLOCK);
    thread_ = std::thread([this] { loop(); });
  }
  ~FakeFirmware() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    if (master_ >= 0) ::close(master_);
  }
  const std::string& path() const { return path_; }
  // Printed right after the prompt that ends an answer (read_run's next streamed row).
  void setAfterPrompt(const std::string& text) {
    std::lock_guard<std::mutex> l(m_);
    after_prompt_ = text;
  }
  // What a board prints after a reset: a banner and the prompt.
  void boot() { say("thrustcal fake firmware\r\n" + prompt_); }
  void say(const std::string& text) {
    std::lock_guard<std::mutex> l(m_);
    out_ += text;
  }
  std::vector<std::string> lines() {
    std::lock_guard<std::mutex> l(m_);
    return lines_;
  }
  std::string raw() {
    std::lock_guard<std::mutex> l(m_);
    return raw_;
  }
  void hangUp() {
    stop_ = true;
    thread_.join();
    ::close(master_);
    master_ = -1;
  }

 private:
  void loop() {
    std::string cur;
    while (!stop_) {
      char buf[256];
      const ssize_t n = ::read(master_, buf, sizeof buf);
      for (ssize_t i = 0; i < n; ++i) {
        std::lock_guard<std::mutex> l(m_);
        raw_.push_back(buf[i]);
        if (buf[i] == '\r') {
          lines_.push_back(cur);
          out_ += cur + "\r\n";
          if (!cur.empty()) out_ += answer_(cur);
          out_ += prompt_;
          if (!cur.empty()) out_ += after_prompt_;
          cur.clear();
        } else {
          cur.push_back(buf[i]);
        }
      }
      {
        std::lock_guard<std::mutex> l(m_);
        if (!out_.empty()) {
          const ssize_t w = ::write(master_, out_.data(), out_.size());
          if (w > 0) out_.erase(0, static_cast<std::size_t>(w));
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  std::string prompt_;
  Answer answer_;
  int master_ = -1;
  std::string path_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::mutex m_;
  std::string out_, raw_;
  std::vector<std::string> lines_;
  std::string after_prompt_;
};

// What gather_store of today says to `strict on`; what one with strict mode says.
std::string withoutStrict(const std::string& line) {
  if (line.rfind("strict", 0) == 0) return "error: unknown command 'strict'; type help for the commands\r\n";
  return "answer to " + line + "\r\n";
}
std::string withStrict(const std::string& line) {
  const auto star = line.find('*');
  if (star == std::string::npos) return "error: strict mode: checksum missing\r\n";
  if (board::checksumHex(line.substr(0, star)) != line.substr(star + 1)) return "error: checksum\r\n";
  if (line.rfind("strict on*", 0) == 0) return "strict on: lines need *HH\r\n";
  return "answer to " + line.substr(0, star) + "\r\n";
}

TEST(ConsoleClient, BootFindsThePromptAndTellsTheImage) {
  FakeFirmware fw("rr> ", withoutStrict);
  board::SerialPort port(fw.path());
  board::ConsoleClient con(port);
  fw.boot();
  const auto lines = con.waitForBoot(5);
  EXPECT_EQ(con.image(), board::Image::kReadRun);
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.back(), "thrustcal fake firmware");
}

TEST(ConsoleClient, FirmwareWithoutStrictModeGetsPlainLines) {
  FakeFirmware fw("gs> ", withoutStrict);
  board::SerialPort port(fw.path());
  board::ConsoleClient con(port);
  fw.boot();
  con.waitForBoot(5);
  EXPECT_FALSE(con.enableStrict());
  const auto answer = con.mustCommand("motor 2");
  EXPECT_EQ(answer, std::vector<std::string>{"answer to motor 2"});  // no echo, no prompt
  EXPECT_EQ(fw.lines().back(), "motor 2");
}

TEST(ConsoleClient, FirmwareWithStrictModeGetsEveryLineChecksummed) {
  FakeFirmware fw("gs> ", withStrict);
  board::SerialPort port(fw.path());
  board::ConsoleClient con(port);
  fw.boot();
  con.waitForBoot(5);
  EXPECT_TRUE(con.enableStrict());
  EXPECT_EQ(fw.lines().front(), "strict on*2A");
  EXPECT_EQ(con.mustCommand("motor 2"), std::vector<std::string>{"answer to motor 2"});
  EXPECT_EQ(fw.lines().back(), "motor 2*" + board::checksumHex("motor 2"));
}

TEST(ConsoleClient, ARefusalThrowsWithTheCommandAndTheErrorLine) {
  FakeFirmware fw("gs> ", [](const std::string&) { return std::string("error: nope\r\n"); });
  board::SerialPort port(fw.path());
  board::ConsoleClient con(port);
  fw.boot();
  con.waitForBoot(5);
  try {
    con.mustCommand("store 1");
    FAIL();
  } catch (const board::CommandRefused& e) {
    EXPECT_NE(std::string(e.what()).find("refused \"store 1\": error: nope"), std::string::npos);
  }
}

TEST(ConsoleClient, ATimeOutOfAMotorCommandSendsTheAbortKeyThenOneEmptyLine) {
  FakeFirmware fw("gs> ", withoutStrict);
  board::SerialPort port(fw.path());
  board::ConsoleClient con(port);
  fw.boot();
  con.waitForBoot(5);
  // when: no answer in time (a limit of 0 s: the answer cannot be there yet)
  bool timed_out = false;
  try {
    con.command("sweep", board::CommandLimits{0.0, 0.0, true});
  } catch (const board::BoardTimeout& e) {
    timed_out = true;
    EXPECT_NE(std::string(e.what()).find("abort key sent"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(timed_out);
  // then: the line, the abort key (CR) and one empty line (CR) went out, nothing else
  EXPECT_EQ(fw.raw(), "sweep\r\r\r");
  // and the console is in step again
  EXPECT_EQ(con.mustCommand("show"), std::vector<std::string>{"answer to show"});
}

TEST(ConsoleClient, APromptFollowedAtOnceByAStreamRowStillEndsTheAnswer) {
  // given: read_run streaming: its next CSV row comes right after the prompt, on the same line
  FakeFirmware fw("rr> ", [](const std::string&) {
    return std::string("# liftoff done: motors stopped\r\n");
  });
  board::SerialPort port(fw.path());
  board::ConsoleClient con(port);
  fw.boot();
  con.waitForBoot(5);
  fw.setAfterPrompt("0.100,1000,1000,1000,1000,12.550\r\n");
  // when
  const auto lines = con.command("liftoff 300", board::CommandLimits{3.0});
  // then: the answer ends at the prompt, whatever followed it
  ASSERT_FALSE(lines.empty());
  EXPECT_NE(std::find(lines.begin(), lines.end(), "# liftoff done: motors stopped"), lines.end());
}

TEST(ConsoleClient, ALostPortIsAPortError) {
  auto fw = std::make_unique<FakeFirmware>("gs> ", withoutStrict);
  board::SerialPort port(fw->path());
  board::ConsoleClient con(port);
  fw->boot();
  con.waitForBoot(5);
  fw->hangUp();
  EXPECT_THROW(con.command("motor 0", board::CommandLimits{5.0}), board::PortError);
}

}  // namespace

// Shared by the board path tests: where the images, the bootloader and avrdude are, a pattern
// EEPROM image, running `thrustcal` as a child process, and a simulated board on a pty.
#pragma once
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sim/sim_board.hpp"

extern char** environ;

namespace board_test {

// A whole file as text (empty if it cannot be read).
inline std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

namespace fs = std::filesystem;

inline std::string image(const std::string& name, const std::string& ext) {
  return (fs::path(THRUSTCAL_AVR_BUILD_DIR) / "firmware" / name / (name + ext)).string();
}

// Skips the test unless the AVR images, Debian's bootloader and avrdude are there.
#define BOARD_REQUIRE_TOOLS()                                                                    \
  do {                                                                                           \
    for (const char* n : {"gather_store", "read_run"})                                          \
      if (!std::filesystem::exists(board_test::image(n, ".hex")))                               \
        GTEST_SKIP() << "no AVR image " << board_test::image(n, ".hex")                         \
                     << ": build the AVR tree first (tools/test.sh does)";                       \
    if (!std::filesystem::exists(sim::kDefaultBootloaderHex))                                   \
      GTEST_SKIP() << "no " << sim::kDefaultBootloaderHex << ": apt-get install arduino-core-avr"; \
    if (::access("/usr/bin/avrdude", X_OK) != 0)                                                \
      GTEST_SKIP() << "no /usr/bin/avrdude: apt-get install avrdude";                            \
  } while (0)

// A value for every EEPROM address that tells it apart from the others a misaddressed
// transfer would hit: (low byte) XOR (page * 0xEF). Within a 256-byte page every byte differs;
// the same offset differs in every other page; twice the address (what the stock bootloader
// reads) holds another value at 4088 of the 4095 addresses (8 bits cannot do better for all).
inline uint8_t patternByte(uint32_t addr) {
  return static_cast<uint8_t>((addr & 0xFF) ^ ((addr >> 8) * 0xEF));
}
inline std::vector<uint8_t> patternImage() {
  std::vector<uint8_t> img(4096);
  for (uint32_t a = 0; a < img.size(); ++a) img[a] = patternByte(a);
  return img;
}

inline std::string tempDir(const std::string& name) {
  const fs::path dir = fs::path(BOARD_TEST_TMP) / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

struct ProcessResult {
  int exit_code = -1;
  std::string output;  // stdout + stderr
  double wall_s = 0;
};

// A child process with its stdout+stderr in a pipe.
class Process {
 public:
  explicit Process(const std::vector<std::string>& args) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("pipe");
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 2);
    posix_spawn_file_actions_addclose(&fa, fds[1]);
    posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    t0_ = std::chrono::steady_clock::now();
    const int err = ::posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    ::close(fds[1]);
    fd_ = fds[0];
    if (err != 0) throw std::runtime_error("cannot start " + args[0]);
  }
  ~Process() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (fd_ >= 0) ::close(fd_);
  }
  // Reads what the child printed so far (waits up to `timeout_s` for something).
  void pump(double timeout_s) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout_s * 1000)) <= 0) return;
    char buf[4096];
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n > 0) out_.append(buf, static_cast<std::size_t>(n));
  }
  // Waits for the child to end (killing it after `timeout_s`).
  ProcessResult wait(double timeout_s) {
    ProcessResult r;
    bool killed = false;
    const auto start = std::chrono::steady_clock::now();
    auto waited = [&] {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    for (;;) {
      pump(0.05);
      int status = 0;
      const pid_t done = ::waitpid(pid_, &status, WNOHANG);
      if (done == pid_) {
        for (int i = 0; i < 100; ++i) pump(0.0);
        r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        pid_ = -1;
        break;
      }
      if (!killed && waited() > timeout_s) {
        ::kill(pid_, SIGKILL);
        killed = true;
        out_ += "\n[killed by the test after " + std::to_string(timeout_s) + " s]\n";
      }
    }
    r.output = out_;
    r.wall_s = elapsed();
    return r;
  }
  void signal(int sig) { ::kill(pid_, sig); }
  pid_t pid() const { return pid_; }
  const std::string& output() const { return out_; }
  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }

 private:
  pid_t pid_ = -1;
  int fd_ = -1;
  std::string out_;
  std::chrono::steady_clock::time_point t0_;
};

inline ProcessResult run(const std::vector<std::string>& args, double timeout_s) {
  Process p(args);
  return p.wait(timeout_s);
}

// A simulated Mega2560 on a pty, its bridge running in a thread.
class SimulatedBoard : public ::testing::Test {
 protected:
  void SetUp() override { BOARD_REQUIRE_TOOLS(); }
  void TearDown() override {
    if (sb) sb->link().stop();
  }
  void start(const std::string& app, std::vector<uint8_t> eeprom = {}) {
    sim::SimBoardOptions o;
    o.application = app;
    o.eeprom = std::move(eeprom);
    o.pty.on_reset = [this] {
      ++resets;
      if (on_reset) on_reset(resets);
    };
    sb = std::make_unique<sim::SimBoard>(o);
    sb->link().start(sim::Pacing{1.0, 0.0});
    port = sb->link().path();
  }
  std::vector<uint8_t> eeprom() {
    return sb->link().paused([&] { return sb->board().eeprom(); });
  }

  std::unique_ptr<sim::SimBoard> sb;
  std::string port;
  int resets = 0;                     // client resets (bridge thread)
  std::function<void(int)> on_reset;  // runs in the bridge thread, simulation stopped
};

}  // namespace board_test

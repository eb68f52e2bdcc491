#include "sim/pty_bridge.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>

namespace sim {

PtyBridge::PtyBridge(Board& board) : board_(board) {
  master_fd_ = ::posix_openpt(O_RDWR | O_NOCTTY);
  if (master_fd_ < 0 || ::grantpt(master_fd_) != 0 || ::unlockpt(master_fd_) != 0)
    throw std::runtime_error(fmt::format(
        "cannot open a pseudo-terminal ({}); is /dev/pts mounted?", std::strerror(errno)));
  const char* name = ::ptsname(master_fd_);
  if (!name) throw std::runtime_error("ptsname failed: no terminal name for the pty");
  path_ = name;
  slave_fd_ = ::open(path_.c_str(), O_RDWR | O_NOCTTY);
  if (slave_fd_ >= 0) {
    termios tio {};
    if (::tcgetattr(slave_fd_, &tio) == 0) {
      ::cfmakeraw(&tio);
      ::cfsetispeed(&tio, B115200);
      ::cfsetospeed(&tio, B115200);
      ::tcsetattr(slave_fd_, TCSANOW, &tio);
    }
  }
  ::fcntl(master_fd_, F_SETFL, ::fcntl(master_fd_, F_GETFL) | O_NONBLOCK);
  board_.addOutputListener([this](uint8_t byte) { pending_out_.push_back(static_cast<char>(byte)); });
}

PtyBridge::~PtyBridge() {
  if (slave_fd_ >= 0) ::close(slave_fd_);
  if (master_fd_ >= 0) ::close(master_fd_);
}

void PtyBridge::run(double speed, double duration_s, const std::atomic<bool>& stop,
                    double slice_s) {
  using clock = std::chrono::steady_clock;
  const auto wall0 = clock::now();
  const double sim0 = board_.timeS();
  char buf[256];
  while (!stop.load()) {
    const double elapsed_sim = board_.timeS() - sim0;
    if (duration_s > 0 && elapsed_sim >= duration_s) break;
    // input from the terminal
    for (;;) {
      const ssize_t n = ::read(master_fd_, buf, sizeof buf);
      if (n <= 0) break;
      board_.sendText(std::string(buf, static_cast<std::size_t>(n)));
    }
    board_.runFor(slice_s);
    // output to the terminal (dropped if nobody has it open and the pty buffer is full)
    while (!pending_out_.empty()) {
      const ssize_t n = ::write(master_fd_, pending_out_.data(), pending_out_.size());
      if (n <= 0) {
        if (pending_out_.size() > 65536) pending_out_.clear();
        break;
      }
      pending_out_.erase(0, static_cast<std::size_t>(n));
    }
    if (speed > 0) {
      const double target_wall = (board_.timeS() - sim0) / speed;
      const double wall = std::chrono::duration<double>(clock::now() - wall0).count();
      if (target_wall > wall)
        std::this_thread::sleep_for(std::chrono::duration<double>(target_wall - wall));
    }
  }
}

}  // namespace sim

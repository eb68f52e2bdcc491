#include "sim/pty_bridge.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>

namespace sim {
namespace {

using Clock = std::chrono::steady_clock;

constexpr std::size_t kOutLineCap = 32;         // prompts are short; longer lines are not
constexpr std::size_t kBackpressureBytes = 16384;  // output the client has not read yet
constexpr double kIdleSliceS = 0.001;           // paced: react to input within 1 ms
constexpr double kBusySliceS = 0.010;
constexpr double kQuietAfterIoS = 0.002;        // bytes moved this recently: still busy
constexpr double kMaxLagS = 0.2;                // paced run this far behind: stop catching up

// A console prompt alone on its line: "gs> ", "rr> ", "p> " (lower case, digits, '_').
bool isPrompt(const std::string& line) {
  if (line.size() < 3 || line.size() > 10) return false;
  if (line.compare(line.size() - 2, 2, "> ") != 0) return false;
  for (std::size_t i = 0; i + 2 < line.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(line[i]);
    if (!(std::islower(c) || std::isdigit(c) || c == '_')) return false;
  }
  return true;
}

void setRaw(int fd) {
  termios tio {};
  if (::tcgetattr(fd, &tio) == 0) {
    ::cfmakeraw(&tio);
    ::cfsetispeed(&tio, B115200);
    ::cfsetospeed(&tio, B115200);
    ::tcsetattr(fd, TCSANOW, &tio);
  }
}

}  // namespace

RawPty openRawPty() {
  RawPty pty;
  pty.master_fd = ::posix_openpt(O_RDWR | O_NOCTTY);
  if (pty.master_fd < 0 || ::grantpt(pty.master_fd) != 0 || ::unlockpt(pty.master_fd) != 0) {
    const int error = errno;
    if (pty.master_fd >= 0) ::close(pty.master_fd);
    throw std::runtime_error(fmt::format(
        "cannot open a pseudo-terminal ({}); is /dev/pts mounted?", std::strerror(error)));
  }
  const char* name = ::ptsname(pty.master_fd);
  if (!name) {
    ::close(pty.master_fd);
    throw std::runtime_error("ptsname failed: no terminal name for the pty");
  }
  pty.path = name;
  // Raw mode on the slave side; the pty keeps it between clients.
  pty.slave_fd = ::open(pty.path.c_str(), O_RDWR | O_NOCTTY);
  if (pty.slave_fd >= 0) setRaw(pty.slave_fd);
  ::fcntl(pty.master_fd, F_SETFL, ::fcntl(pty.master_fd, F_GETFL) | O_NONBLOCK);
  return pty;
}

struct PtyBridge::LoopState {
  double idle_slice_s, busy_slice_s;
};

PtyBridge::PtyBridge(Board& board, PtyOptions options)
    : board_(board), options_(std::move(options)) {
  const RawPty pty = openRawPty();
  master_fd_ = pty.master_fd;
  slave_fd_ = pty.slave_fd;
  path_ = pty.path;
  if (options_.reset_on_open) {
    // Packet mode: the slave's tcflush shows up as a status byte on the master. With our own
    // slave descriptor closed the master sees POLLHUP until a client opens the port.
    int one = 1;
    if (::ioctl(master_fd_, TIOCPKT, &one) != 0)
      throw std::runtime_error(fmt::format("cannot put the pty in packet mode ({})",
                                           std::strerror(errno)));
    if (slave_fd_ >= 0) ::close(slave_fd_);
    slave_fd_ = -1;
  }
  if (!options_.link_path.empty()) {
    struct stat st {};
    if (::lstat(options_.link_path.c_str(), &st) == 0) {
      if (!S_ISLNK(st.st_mode))
        throw std::runtime_error(fmt::format(
            "{}: exists and is not a symlink; choose another --link path (it is replaced only "
            "when it is a link from an earlier run)",
            options_.link_path));
      ::unlink(options_.link_path.c_str());
    }
    if (::symlink(path_.c_str(), options_.link_path.c_str()) != 0)
      throw std::runtime_error(fmt::format("{}: cannot make the link to {} ({})",
                                           options_.link_path, path_, std::strerror(errno)));
    link_made_ = true;
  }
  board_.addOutputListener([this](uint8_t byte) { trackOutput(byte); });
}

PtyBridge::~PtyBridge() {
  try {
    stop();
  } catch (...) {
  }
  if (link_made_) {
    char target[256] = {};
    const ssize_t n = ::readlink(options_.link_path.c_str(), target, sizeof target - 1);
    if (n > 0 && path_ == std::string(target, static_cast<std::size_t>(n)))
      ::unlink(options_.link_path.c_str());
  }
  if (slave_fd_ >= 0) ::close(slave_fd_);
  if (master_fd_ >= 0) ::close(master_fd_);
}

void PtyBridge::say(const std::string& line) const {
  if (options_.log) options_.log(line);
}

// ---- activity tracking -----------------------------------------------------------------------

void PtyBridge::trackInput(const char* data, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(data[i]);
    if (board_.inBootloader()) {  // binary STK500v2 messages: no lines, no prompts
      in_line_ = false;
      command_running_ = false;
      continue;
    }
    if (c == '\r' || c == '\n') {
      if (in_line_) command_running_ = true;
      in_line_ = false;
    } else if (c >= 0x20 && c < 0x7F) {
      in_line_ = true;
    }
  }
}

void PtyBridge::trackOutput(uint8_t byte) {
  last_output_s_ = board_.timeS();
  if (!options_.reset_on_open || !hup_) pending_out_.push_back(static_cast<char>(byte));
  if (byte == '\n') {
    out_line_.clear();
    return;
  }
  if (byte == '\r') return;
  out_line_.push_back(static_cast<char>(byte));
  if (out_line_.size() > kOutLineCap) out_line_.erase(0, out_line_.size() - kOutLineCap);
  if (command_running_ && isPrompt(out_line_)) command_running_ = false;
}

bool anyEscAbove(const Board& board, double us) {
  for (int ch = 0; ch < kEscChannels; ++ch)
    if (board.escPulseUs(ch) > us) return true;
  return false;
}

bool PtyBridge::busy() const {
  if (board_.pendingInput() > 0 || command_running_) return true;
  return board_.timeS() - std::max(last_output_s_, last_input_s_) < kQuietAfterIoS;
}

// ---- pty I/O ---------------------------------------------------------------------------------

void PtyBridge::serviceInput() {
  if (options_.reset_on_open) {
    pollfd p{master_fd_, POLLIN, 0};
    ::poll(&p, 1, 0);
    const bool hup_now = (p.revents & POLLHUP) != 0;
    if (hup_ && !hup_now) {
      connected_ = true;
      say("a client opened the port");
    } else if (!hup_ && hup_now) {
      connected_ = false;
      pending_out_.clear();
      say("the client closed the port");
    }
    hup_ = hup_now;
    if (hup_) return;
  }
  char buf[512];
  for (;;) {
    const ssize_t n = ::read(master_fd_, buf, sizeof buf);
    if (n <= 0) break;
    const char* data = buf;
    std::size_t len = static_cast<std::size_t>(n);
    if (options_.reset_on_open) {  // packet mode: a status byte first
      const unsigned char status = static_cast<unsigned char>(buf[0]);
      ++data;
      --len;
      if (status != TIOCPKT_DATA) {
        // Every flush resets: clients flush right after they open the port (avrdude, termios
        // clients), and a close and the next open can fall between two polls (no POLLHUP seen).
        if (status & (TIOCPKT_FLUSHREAD | TIOCPKT_FLUSHWRITE)) {
          board_.reset();
          client_resets_.fetch_add(1);
          pending_out_.clear();
          out_line_.clear();
          in_line_ = false;
          command_running_ = false;
          say(fmt::format("reset (the client flushed the port, as a DTR pulse does){}",
                          board_.hasBootloader() ? ": bootloader" : ""));
          if (options_.on_reset) options_.on_reset();
        }
        continue;
      }
    }
    if (len == 0) continue;
    last_input_s_ = board_.timeS();
    board_.sendText(std::string(data, len));
    trackInput(data, len);
  }
}

void PtyBridge::deliverOutput() {
  while (!pending_out_.empty()) {
    const ssize_t n = ::write(master_fd_, pending_out_.data(), pending_out_.size());
    if (n <= 0) {
      // Nobody reads (console mode with no client): keep a bounded backlog.
      if (!options_.reset_on_open && pending_out_.size() > 65536) pending_out_.clear();
      break;
    }
    pending_out_.erase(0, static_cast<std::size_t>(n));
  }
}

// Sleeps up to `seconds` of wall time, waking early when the client sends something.
void PtyBridge::waitWall(double seconds) {
  if (seconds <= 0) return;
  timespec ts{static_cast<time_t>(seconds), static_cast<long>((seconds - static_cast<time_t>(seconds)) * 1e9)};
  if (options_.reset_on_open && hup_) {
    ::nanosleep(&ts, nullptr);  // a hung-up master polls readable forever
    return;
  }
  pollfd p{master_fd_, POLLIN, 0};
  ::ppoll(&p, 1, &ts, nullptr);
}

// ---- running ---------------------------------------------------------------------------------

void PtyBridge::run(double speed, double duration_s, const std::atomic<bool>& stop,
                    double slice_s) {
  loop(Pacing{speed, speed}, duration_s, stop, LoopState{slice_s, slice_s});
}

void PtyBridge::run(const Pacing& pacing, double duration_s, const std::atomic<bool>& stop) {
  loop(pacing, duration_s, stop, LoopState{kIdleSliceS, kBusySliceS});
}

void PtyBridge::loop(const Pacing& pacing, double duration_s, const std::atomic<bool>& stop,
                     const LoopState& st) {
  double sim0, anchor_sim;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    sim0 = anchor_sim = board_.timeS();
  }
  auto anchor_wall = Clock::now();
  bool was_busy = false;
  bool was_real_time = false;
  while (!stop.load()) {
    while (pause_requests_.load() > 0) std::this_thread::yield();
    bool is_busy = false;
    bool real_time = false;
    bool backlog = false;
    double sim_now = 0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (duration_s > 0 && board_.timeS() - sim0 >= duration_s) break;
      serviceInput();
      is_busy = busy();
      real_time = options_.real_time_while && options_.real_time_while();
      sim_now = board_.timeS();
      if (is_busy != was_busy || real_time != was_real_time) {
        // a new pace starts from here; no catching up across modes
        anchor_sim = sim_now;
        anchor_wall = Clock::now();
        was_busy = is_busy;
        was_real_time = real_time;
      }
      // A client that does not keep up with the output holds the board back (no bytes lost).
      backlog = options_.reset_on_open && !hup_ && pending_out_.size() > kBackpressureBytes;
      if (!backlog) board_.runFor(is_busy ? st.busy_slice_s : st.idle_slice_s);
      deliverOutput();
      sim_now = board_.timeS();
    }
    if (backlog) {
      pollfd p{master_fd_, POLLOUT, 0};
      ::poll(&p, 1, 5);
      anchor_sim = sim_now;
      anchor_wall = Clock::now();
      continue;
    }
    double speed = is_busy ? pacing.busy_speed : pacing.idle_speed;
    if (real_time && (speed <= 0 || speed > 1.0)) speed = 1.0;
    if (speed <= 0) continue;
    const double due = (sim_now - anchor_sim) / speed;
    const double elapsed = std::chrono::duration<double>(Clock::now() - anchor_wall).count();
    if (due > elapsed) {
      waitWall(due - elapsed);
    } else if (elapsed - due > kMaxLagS) {  // the host cannot keep up: do not race to catch up
      anchor_sim = sim_now;
      anchor_wall = Clock::now();
    }
  }
}

void PtyBridge::start(const Pacing& pacing) {
  if (thread_.joinable()) throw std::logic_error("PtyBridge::start: already running");
  thread_stop_ = false;
  thread_error_ = nullptr;
  thread_ = std::thread([this, pacing] {
    try {
      run(pacing, 0, thread_stop_);
    } catch (...) {
      thread_error_ = std::current_exception();
      // The client sees the port go dead, as when a board loses power.
      std::lock_guard<std::mutex> lock(mutex_);
      pending_out_.clear();
      ::close(master_fd_);
      master_fd_ = -1;
    }
  });
}

void PtyBridge::stop() {
  if (!thread_.joinable()) return;
  thread_stop_ = true;
  thread_.join();
  if (thread_error_) {
    auto e = thread_error_;
    thread_error_ = nullptr;
    std::rethrow_exception(e);
  }
}

}  // namespace sim

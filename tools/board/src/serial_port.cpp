#include "board/serial_port.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <climits>
#include <cstdlib>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

#include <fmt/format.h>

namespace board {
namespace {

speed_t baudConstant(unsigned baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    default:
      throw PortError(fmt::format("baud {} is not supported; the Mega2560's bootloader uses {} "
                                  "and the images {}",
                                  baud, hal::kBootloaderBaud, hal::kUartBaud));
  }
}

const char* kPortAdvice =
    "is the board plugged in? (a Mega2560 shows up as /dev/ttyACM0, clones with a CH340 as "
    "/dev/ttyUSB0; see `ls /dev/ttyACM* /dev/ttyUSB*`); a simulated board prints its port, or "
    "pass its --link path";

}  // namespace

void requirePort(const std::string& path) {
  struct stat st {};
  if (path.empty()) throw PortError(fmt::format("no serial port given (--port); {}", kPortAdvice));
  if (::stat(path.c_str(), &st) != 0)
    throw PortError(fmt::format("{}: no such serial port; {}", path, kPortAdvice));
  if (!S_ISCHR(st.st_mode))
    throw PortError(fmt::format("{}: not a serial port (not a character device); {}", path,
                                kPortAdvice));
}

bool abortOnReturningPort(const std::string& path, double within_s) {
  // A pseudo-terminal that went away (a simulated board ended) never comes back, and its
  // number may already belong to another one: never open it again.
  char real[PATH_MAX];
  if (::realpath(path.c_str(), real) == nullptr || std::strncmp(real, "/dev/pts/", 9) == 0)
    return false;
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < within_s) {
    try {
      SerialPort again(path);  // the open pulses DTR: the board resets, its ESC outputs stop
      again.write("\r");       // and the abort key, for a board that did not reset
      return true;
    } catch (const PortError&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
  return false;
}

SerialPort::SerialPort(const std::string& path, unsigned baud, bool reset) : path_(path) {
  requirePort(path);
  const speed_t speed = baudConstant(baud);
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd_ < 0) {
    const int err = errno;
    if (err == EACCES)
      throw PortError(fmt::format("{}: permission denied; add yourself to the dialout group "
                                  "(sudo adduser $USER dialout, then log in again)",
                                  path));
    if (err == EBUSY)
      throw PortError(fmt::format("{}: busy; close the terminal (screen, picocom, the Arduino "
                                  "IDE's serial monitor) that has it open",
                                  path));
    throw PortError(fmt::format("{}: cannot open ({}); {}", path, std::strerror(err), kPortAdvice));
  }
  termios tio {};
  if (::tcgetattr(fd_, &tio) != 0) {
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    throw PortError(fmt::format("{}: not a terminal ({}); pass the board's serial port", path,
                                std::strerror(err)));
  }
  ::cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD | HUPCL;
  tio.c_cflag &= ~(CRTSCTS | CSTOPB | PARENB);
  tio.c_iflag &= ~(IXON | IXOFF | IXANY);
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  ::cfsetispeed(&tio, speed);
  ::cfsetospeed(&tio, speed);
  ::tcsetattr(fd_, TCSANOW, &tio);
  if (reset) {
    // DTR/RTS low, then high: the auto-reset of an Arduino (a pty has no modem lines; the
    // ioctls fail there and the flush below does the job).
    int lines = TIOCM_DTR | TIOCM_RTS;
    if (::ioctl(fd_, TIOCMBIC, &lines) == 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      ::ioctl(fd_, TIOCMBIS, &lines);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ::tcflush(fd_, TCIOFLUSH);
  }
}

SerialPort::~SerialPort() { close(); }

void SerialPort::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

void SerialPort::lost(const char* during) const {
  throw PortError(fmt::format("{}: the port went away while {} (unplugged, or the simulated "
                              "board ended); plug it back in and start again",
                              path_, during));
}

void SerialPort::write(const std::string& bytes) {
  if (fd_ < 0) lost("writing");
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
      pollfd p{fd_, POLLOUT, 0};
      ::poll(&p, 1, 100);
      if (p.revents & (POLLHUP | POLLERR | POLLNVAL)) lost("writing");
      continue;
    }
    lost("writing");
  }
}

std::string SerialPort::read(double timeout_s) {
  if (fd_ < 0) lost("reading");
  pollfd p{fd_, POLLIN, 0};
  const int ms = timeout_s <= 0 ? 0 : static_cast<int>(timeout_s * 1000 + 0.5);
  const int r = ::poll(&p, 1, ms);
  if (r < 0) {
    if (errno == EINTR) return {};
    lost("reading");
  }
  if (r == 0) return {};
  std::string out;
  char buf[1024];
  for (;;) {
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n > 0) {
      out.append(buf, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) break;
    if (out.empty()) lost("reading");  // EOF or EIO: hung up
    break;
  }
  return out;
}

void SerialPort::discardInput() {
  if (fd_ >= 0) ::tcflush(fd_, TCIFLUSH);
}

}  // namespace board

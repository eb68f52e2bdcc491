// A serial port through termios, the way avrdude and a terminal open an Arduino Mega2560:
// 115200 8N1, raw, no flow control. Opening resets the board: DTR and RTS go low for 50 ms and
// high again (the USB-serial adapter's DTR pulses the ATmega2560's reset line through a
// capacitor), then both directions are flushed. A simulated board (`thrustcal sim board`) sits
// on a pseudo-terminal, which has no DTR: it resets on that flush instead.
#pragma once
#include <stdexcept>
#include <string>

#include "hal/board.hpp"

namespace board {

// The port is missing, cannot be opened, or was lost (unplugged, the simulator ended);
// what() says which and what to do.
class PortError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class SerialPort {
 public:
  // Opens `path`; `reset` pulses DTR/RTS and flushes (see above). Throws PortError.
  explicit SerialPort(const std::string& path, unsigned baud = hal::kUartBaud, bool reset = true);
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  const std::string& path() const { return path_; }
  // Writes every byte (waits while the driver's buffer is full). Throws PortError when the
  // port is gone.
  void write(const std::string& bytes);
  // What arrives within `timeout_s` (returns as soon as anything came; "" on timeout). Throws
  // PortError when the port is gone.
  std::string read(double timeout_s);
  // Drops received bytes not read yet.
  void discardInput();
  void close();
  bool isOpen() const { return fd_ >= 0; }

 private:
  [[noreturn]] void lost(const char* during) const;
  std::string path_;
  int fd_ = -1;
};

// After a lost port (a USB glitch): tries to open `path` again for up to `within_s`; when it
// opens, that open resets the board (DTR) and the abort key is sent too. True if it did.
// Never for a pseudo-terminal (a simulated board does not come back; its number is reused).
bool abortOnReturningPort(const std::string& path, double within_s);

// Throws PortError unless `path` names an existing character device (a serial port or a pty),
// with what to do: the board's usual names, a simulated board's link.
void requirePort(const std::string& path);

}  // namespace board

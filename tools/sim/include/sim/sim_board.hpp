// `thrustcal sim board`: a simulated Arduino Mega2560 as a user meets a real one on USB.
//
// The flash holds a bootloader (Debian's STK500v2 for the Mega2560 by default) and optionally
// an application; every reset starts the bootloader, which waits ~1 s for avrdude and then
// starts the application. UART0 is on a pty (PtyBridge, board mode): opening and flushing the
// port resets the board, time keeps the wall clock while idle and runs fast while bytes flow.
// Whatever avrdude writes stays in the flash for the run; the EEPROM is loaded from and saved
// to an Intel HEX file.
//
// The plant follows the image, re-checked at every reset: gather_store gets the thesis bench
// (the motor of --slot on the load cell), read_run the tethered quad (four motors), found by the
// banner text in the flash; --rig bench|quad fixes one.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/board.hpp"
#include "sim/pty_bridge.hpp"

namespace sim {

struct BenchRig;
struct QuadRig;

// Debian's arduino-core-avr: the Mega2560's STK500v2 bootloader.
constexpr const char* kDefaultBootloaderHex =
    "/usr/share/arduino/hardware/arduino/avr/bootloaders/stk500v2/stk500boot_v2_mega2560.hex";

// What a flash image is, from the banner strings the images keep in flash.
enum class FlashApp { kNone, kGatherStore, kReadRun, kOther };
FlashApp identifyApp(const std::vector<uint8_t>& flash, uint32_t boot_address);
const char* flashAppName(FlashApp app);

struct SimBoardOptions {
  std::string bootloader_hex = kDefaultBootloaderHex;
  std::string application;          // .elf or .hex; "" = the bootloader alone (a new board)
  std::vector<uint8_t> eeprom;      // empty: erased
  std::string rig = "auto";         // auto (follow the image), bench, quad
  std::string preset = "kv1100_9x4.7";
  std::vector<uint64_t> seeds = {1, 2, 3, 4};  // motor per slot (the bench mounts seeds[slot])
  double variation = 0.03;
  int bench_slot = 0;               // ESC output / slot of the motor on the bench
  double lipo_soc = 1.0;            // the pack on the bench and on the quad
  PtyOptions pty;                   // reset_on_open is forced on; on_reset runs after the
                                    // plant was fitted to the image
};

class SimBoard {
 public:
  // Throws BoardError / std::runtime_error with what to do (missing bootloader: install
  // arduino-core-avr).
  explicit SimBoard(SimBoardOptions options);
  ~SimBoard();

  Board& board() { return *board_; }
  PtyBridge& link() { return *link_; }
  // The plant now wired: "bench (motor seed S on ESC K)", "tethered quad", "none".
  std::string rigText() const { return rig_text_; }
  FlashApp app() const { return app_; }
  // The plant now wired (null when the other one is); touch it only inside link().paused().
  BenchRig* bench() { return bench_.get(); }
  QuadRig* quad() { return quad_.get(); }

 private:
  void fitRig();  // called at start and after every client reset (in the bridge's thread)

  SimBoardOptions o_;
  std::unique_ptr<Board> board_;
  std::unique_ptr<BenchRig> bench_;
  std::unique_ptr<QuadRig> quad_;
  std::unique_ptr<PtyBridge> link_;
  std::vector<uint8_t> last_flash_;
  FlashApp app_ = FlashApp::kNone;
  std::string rig_text_ = "none";
};

}  // namespace sim

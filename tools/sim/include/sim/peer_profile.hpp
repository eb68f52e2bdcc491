// A peer for the swap experiment (`thrustcal sim swap --peer FILE`; docs/sim.md, "A peer in the
// swap"): a flight firmware no one here wrote, described by a short text profile so the swap can
// boot it on the gimbal, arm it and command its roll and pitch steps as its pilot would, with
// the same motors, parts and IMU units as fly. The peer has no records: only the rig changes.
//
//   # MultiWii 2.4, QUADX, GY_521, built for the Mega2560 (docs/sim.md)
//   name multiwii24
//   elf MultiWii.elf                   relative to this file's folder, or absolute
//   layout x                           the gimbal layout its mixer flies (plus | x)
//   esc-pins D2,D6,D3,D5               the pins of rig motors 0..3 (docs/hardware.md)
//   spin cw,ccw,cw,ccw                 rig motors 0..3, seen from above (default: the layout's)
//   imu-mount yaw0                     the chip against the airframe (sim/imu_on_board.hpp)
//   rc pwm:A8,A9,A10,A11               as `sim console --rc`
//   channels throttle,roll,pitch,yaw   what the receiver's ch1, ch2, ... carry (or aux1..aux4)
//   neutral throttle=1000              sticks at rest: named ones as given, the others 1500 us
//   eeprom MultiWii.eep.hex            optional: its EEPROM image (Intel HEX), else erased
//   boot-s 3                           simulated seconds from power-up before the sticks move
//   uart-hex 24 4D 3C 00 FA FA         optional: bytes sent on UART0 at boot-s (MSP frames, console
//                                      lines), before any stick moves
//   calibrate throttle=2000,yaw=1000,pitch=1000 hold 1 wait 1.5   optional: sticks that make it
//                                      calibrate (its accelerometer), held HOLD s, then neutral
//                                      for WAIT s before the arming sticks
//   arm throttle=1000,yaw=2000 hold 1.5    the arming sticks, held HOLD s, then neutral again
//   armed-text armed                   optional: what it prints on UART0 once armed
//   hover throttle=1450                the sticks of level flight (after arming)
//   deg-us roll 5                      stick us per degree of the rig's roll (negative: the
//   deg-us pitch -5                    peer's angle has the other sign); 1500 + deg x this
//
// Lines: `KEY VALUE`, `#` starts a comment, blank lines ignored; every key once (deg-us once per
// axis). Required: name, elf, esc-pins, rc, channels (with throttle, roll and pitch), arm,
// hover, deg-us roll and pitch.
#pragma once
#include <array>
#include <map>
#include <string>
#include <vector>

#include "sim/imu_on_board.hpp"
#include "sim/rc_input.hpp"

namespace sim {

struct PeerProfile {
  std::string name;
  std::string elf;     // the path as resolved (the profile's folder for a relative one)
  std::string layout = "x";
  std::array<hal::MegaPin, hal::kEscChannels> esc_pins{};
  std::vector<int> spin;  // +1 ccw / -1 cw per rig motor; empty: the layout's
  ImuMount imu_mount;
  RcSpec rc;
  std::vector<std::string> channels;  // ch1.. : "throttle", "roll", "pitch", "yaw", "aux1".."aux4"
  std::map<std::string, double> neutral, arm, hover;  // stick -> us (neutral: given ones only)
  double arm_hold_s = 1.0;
  std::map<std::string, double> calibrate;  // empty: no calibration sticks
  double calibrate_hold_s = 0, calibrate_wait_s = 0;
  std::string armed_text;
  std::string eeprom;  // resolved path, "" = erased
  std::string uart_bytes;  // uart-hex: sent on UART0 at boot_s
  double boot_s = 1.0;
  double roll_us_per_deg = 0, pitch_us_per_deg = 0;
  std::string file;  // where it was read from

  // The receiver's channel values (ch1..N) for `sticks` over the neutral ones.
  std::vector<double> channelValues(const std::map<std::string, double>& sticks) const;
};

// Throws std::invalid_argument "FILE:LINE: what is wrong; what to write" (a missing key: "FILE:
// ...").
PeerProfile parsePeerProfile(const std::string& text, const std::string& file);
PeerProfile readPeerProfile(const std::string& path);

}  // namespace sim

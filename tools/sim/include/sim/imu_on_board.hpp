// An MPU-6050 part (sim/mpu6050.hpp) soldered onto a simulated board: attached to the board's
// TWI, with the breakout's pull-ups on SDA/SCL, and its sample clock restarted after every
// board reset (the chip keeps its state and its own clock through an AVR reset).
// The truth it measures comes from whoever makes it: a rig (sim/airframe.hpp), or a board at
// rest (levelAtRest()), in the airframe's axes; the chip's mounting turns it into its own.
#pragma once
#include <array>
#include <memory>
#include <string>

#include "sim/board.hpp"
#include "sim/mpu6050.hpp"

namespace sim {

// How the chip sits on the airframe (`--imu-mount`): start with its axes on the body's (x
// forward, y left, z up: the arrows on a GY-521 forward and left, its parts up); if `flipped`,
// turn it over about the body's x axis (upside down: its z down, its y to the right); then turn
// it `yaw_deg` (0, 90, 180, 270) counter-clockwise seen from above. It measures rates and
// specific force in its own axes: v_chip = R^T v_body, R = Rz(yaw) Rx(180 deg if flipped).
// docs/sim.md, "The IMU's mounting", draws the eight mounts.
struct ImuMount {
  int yaw_deg = 0;
  bool flipped = false;
};
// "yaw0", "yaw90", "yaw180", "yaw270", "flip", or "flip" and a yaw separated by a comma in
// either order ("flip,yaw180"). Throws std::invalid_argument with the syntax.
ImuMount parseImuMount(const std::string& spec);
std::string imuMountName(const ImuMount& mount);  // "yaw90", "flip,yaw180"
std::array<double, 3> bodyToChip(const ImuMount& mount, const std::array<double, 3>& body);
extern const char* const kImuMountSyntax;

class ImuOnBoard {
 public:
  // The board must outlive this object. `truth` is in the body's axes; the chip measures it in
  // its own (`mount`).
  ImuOnBoard(Board& board, const Mpu6050Params& params, ImuTruthSource truth, const ImuMount& mount = {});
  ~ImuOnBoard();
  ImuOnBoard(const ImuOnBoard&) = delete;
  ImuOnBoard& operator=(const ImuOnBoard&) = delete;

  Mpu6050& chip() { return *part_.chip; }
  const Mpu6050& chip() const { return *part_.chip; }

 private:
  Board& board_;
  Mpu6050Part part_;
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);  // the reset listener checks it
};

// A board lying still and level at 25 C: no rotation, +1 g on z.
ImuTruthSource levelAtRest();

}  // namespace sim

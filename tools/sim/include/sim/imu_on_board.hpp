// An MPU-6050 part (sim/mpu6050.hpp) soldered onto a simulated board: attached to the board's
// TWI, with the breakout's pull-ups on SDA/SCL, and its sample clock restarted after every
// board reset (the chip keeps its state and its own clock through an AVR reset).
// The truth it measures comes from whoever makes it: a rig (sim/airframe.hpp), or a board at
// rest (levelAtRest()).
#pragma once
#include <memory>

#include "sim/board.hpp"
#include "sim/mpu6050.hpp"

namespace sim {

class ImuOnBoard {
 public:
  // The board must outlive this object.
  ImuOnBoard(Board& board, const Mpu6050Params& params, ImuTruthSource truth);
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

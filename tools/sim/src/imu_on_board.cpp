// The MPU-6050 on a board: see sim/imu_on_board.hpp.
#include "sim/imu_on_board.hpp"

#include "sim/twi.hpp"

namespace sim {

ImuOnBoard::ImuOnBoard(Board& board, const Mpu6050Params& params, ImuTruthSource truth)
    : board_(board) {
  mpu6050_init(board_.avr(), part_, params, std::move(truth));
  mpu6050_attach(board_.avr(), part_, board_.twi().irq());
  board_.twi().setPullUps(true);
  std::weak_ptr<int> alive = alive_;
  board_.addResetListener([this, alive](uint64_t) {
    if (!alive.expired()) mpu6050_rearm(part_);
  });
}

ImuOnBoard::~ImuOnBoard() { board_.twi().setPullUps(false); }

ImuTruthSource levelAtRest() {
  return [](double) { return ImuTruth{}; };
}

}  // namespace sim

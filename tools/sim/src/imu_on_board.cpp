// The MPU-6050 on a board: see sim/imu_on_board.hpp.
#include "sim/imu_on_board.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

#include "sim/twi.hpp"

namespace sim {

const char* const kImuMountSyntax =
    "yaw0, yaw90, yaw180 or yaw270 (the chip turned counter-clockwise seen from above), optionally "
    "with flip (upside down, turned over about the airframe's x axis first), e.g. flip,yaw180";

ImuMount parseImuMount(const std::string& spec) {
  ImuMount m;
  bool yaw_seen = false, flip_seen = false;
  std::size_t start = 0;
  while (start <= spec.size()) {
    const std::size_t comma = std::min(spec.find(',', start), spec.size());
    const std::string word = spec.substr(start, comma - start);
    start = comma + 1;
    if (word == "flip" && !flip_seen) {
      m.flipped = flip_seen = true;
      continue;
    }
    const int yaws[] = {0, 90, 180, 270};
    bool known = false;
    for (int y : yaws)
      if (word == "yaw" + std::to_string(y) && !yaw_seen) {
        m.yaw_deg = y;
        yaw_seen = known = true;
      }
    if (!known)
      throw std::invalid_argument(fmt::format("--imu-mount {}: '{}' is not a mount (or is given twice); write {}",
                                              spec, word, kImuMountSyntax));
  }
  return m;
}

std::string imuMountName(const ImuMount& m) {
  return m.flipped ? fmt::format("flip,yaw{}", m.yaw_deg) : fmt::format("yaw{}", m.yaw_deg);
}

std::array<double, 3> bodyToChip(const ImuMount& m, const std::array<double, 3>& v) {
  std::array<double, 3> u = v;
  for (int k = 0; k < (m.yaw_deg / 90) % 4; ++k) u = {u[1], -u[0], u[2]};  // Rz(-90 deg)
  if (m.flipped) u = {u[0], -u[1], -u[2]};                                 // Rx(180 deg)^T
  return u;
}

ImuOnBoard::ImuOnBoard(Board& board, const Mpu6050Params& params, ImuTruthSource truth, const ImuMount& mount)
    : board_(board) {
  if (mount.yaw_deg % 90 != 0 || mount.yaw_deg < 0 || mount.yaw_deg >= 360)
    throw std::invalid_argument(fmt::format("an IMU mount turns by 0, 90, 180 or 270 deg, not {}", mount.yaw_deg));
  if (mount.yaw_deg != 0 || mount.flipped)
    truth = [body = std::move(truth), mount](double t_s) {
      ImuTruth t = body(t_s);
      t.rate_dps = bodyToChip(mount, t.rate_dps);
      t.specific_force_g = bodyToChip(mount, t.specific_force_g);
      return t;
    };
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

// The virtual airframe: see sim/airframe.hpp.
#include "sim/airframe.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sim/twi.hpp"

namespace sim {

const char* airRigName(AirRig rig) { return rig == AirRig::kSeesaw ? "seesaw" : "gimbal"; }

AirframeRig::AirframeRig(const std::string& elf, const AirframeOptions& options)
    : o_(options), owned_(std::make_unique<Board>(elf)), board_(*owned_) {
  build();
}

AirframeRig::AirframeRig(const FlashImages& images, const AirframeOptions& options)
    : o_(options), owned_(std::make_unique<Board>(images)), board_(*owned_) {
  build();
}

AirframeRig::AirframeRig(Board& existing, const AirframeOptions& options) : o_(options), board_(existing) {
  build();
}

AirframeRig::~AirframeRig() {
  imu_.reset();  // detaches from the TWI before the board (if owned) goes
  board_.clearPlantWiring();
}

void AirframeRig::build() {
  if (o_.rig == AirRig::kSeesaw)
    rig_ = std::make_unique<plant::Seesaw>(o_.seesaw, std::array<plant::ActuatorParams, 2>{o_.motors[0], o_.motors[1]});
  else
    rig_ = std::make_unique<plant::Gimbal>(o_.gimbal, o_.motors);
  if (o_.log_period_s < 0) throw std::invalid_argument("the log period must be > 0 s (0: no log)");
  for (const AirFault& f : o_.faults) checkFault(f);
  pending_ = o_.faults;
  std::stable_sort(pending_.begin(), pending_.end(),
                   [](const AirFault& a, const AirFault& b) { return a.at_s < b.at_s; });
  wire();
}

void AirframeRig::wire() {
  board_.clearPlantWiring();
  board_.setEscPins(o_.esc_pins);
  t0_s_ = board_.timeS();
  const int motors = rig_->motors();
  board_.addPulseListener([this, motors](int ch, double width_us, double t_s) {
    if (ch >= motors) return;
    advanceTo(t_s);
    rig_->setPulse(ch, width_us, t_s - t0_s_);
  });
  board_.setAdcSource([this](int ch) { return ch == hal::kAdcBattery ? vsense_.adcMillivolts() : 0.0; });
  vsense_.settle(rig_->power().restingVoltage_v());
  board_.setTickHook([this](double t_s) { advanceTo(t_s); });
  if (o_.imu) {
    imu_ = std::make_unique<ImuOnBoard>(board_, o_.imu_params, [this](double t_s) {
      advanceTo(t_s);
      const plant::RigTruth t = rig_->truth();
      ImuTruth m;
      m.rate_dps = t.rate_dps;
      m.specific_force_g = t.specific_force_g;
      m.temp_c = o_.imu_temp_c;
      return m;
    }, o_.imu_mount);
  }
}

plant::Seesaw* AirframeRig::seesaw() { return dynamic_cast<plant::Seesaw*>(rig_.get()); }
plant::Gimbal* AirframeRig::gimbal() { return dynamic_cast<plant::Gimbal*>(rig_.get()); }

plant::RigTruth AirframeRig::truth() {
  advanceTo(board_.timeS());
  plant::RigTruth t = rig_->truth();
  t.t_s += t0_s_;  // the board's clock
  return t;
}

void AirframeRig::advanceTo(double board_t_s) {
  // Stops at every fault and log instant on the way, so each happens at its own time.
  const double target = board_t_s - t0_s_;
  for (;;) {
    double next = target;
    const bool fault_due = !pending_.empty() && pending_.front().at_s - t0_s_ <= target;
    if (fault_due) next = std::max(pending_.front().at_s - t0_s_, rig_->time_s());
    const double next_log_s = static_cast<double>(log_rows_) * o_.log_period_s;
    const bool log_due = o_.log_period_s > 0 && next_log_s <= next;
    if (log_due) next = std::max(next_log_s, rig_->time_s());
    const double dt = next - rig_->time_s();
    if (dt > 1e-12) {
      rig_->step(dt);
      vsense_.step(dt, rig_->busVoltage_v());
    }
    if (log_due) {
      ++log_rows_;  // first: a listener that asks for the truth re-enters
      logRow();
    } else if (fault_due) {
      const AirFault f = pending_.front();
      pending_.erase(pending_.begin());
      apply(f);
    } else {
      return;
    }
  }
}

void AirframeRig::schedule(const AirFault& fault) {
  checkFault(fault);
  auto at = std::upper_bound(pending_.begin(), pending_.end(), fault,
                             [](const AirFault& a, const AirFault& b) { return a.at_s < b.at_s; });
  pending_.insert(at, fault);
  advanceTo(board_.timeS());
}

void AirframeRig::checkFault(const AirFault& f) const {
  const bool motor_fault = f.kind == AirFault::Kind::kMotorDead || f.kind == AirFault::Kind::kPropLoss;
  if (motor_fault && (f.motor < 0 || f.motor >= rig_->motors()))
    throw std::invalid_argument(fmt::format(
        "fault {}: the {} has motors 0..{} (ESC outputs); name one of them", f.spec,
        airRigName(o_.rig), rig_->motors() - 1));
  const bool imu_fault = f.kind == AirFault::Kind::kImuNack || f.kind == AirFault::Kind::kImuFreeze;
  if (imu_fault && !o_.imu)
    throw std::invalid_argument(fmt::format("fault {}: there is no IMU on the board; add --imu mpu6050", f.spec));
}

void AirframeRig::apply(const AirFault& f) {
  switch (f.kind) {
    case AirFault::Kind::kImuNack: imu_->chip().setNack(true); break;
    case AirFault::Kind::kImuFreeze: imu_->chip().setFrozen(true); break;
    case AirFault::Kind::kSdaLow: board_.twi().holdSdaLow(f.release_clocks); break;
    case AirFault::Kind::kMotorDead: rig_->killMotor(f.motor); break;
    case AirFault::Kind::kPropLoss: rig_->loseThrust(f.motor, f.share); break;
  }
  applied_.push_back(fmt::format("t={:.4f} s {}", rig_->time_s() + t0_s_, f.spec));
  if (fault_listener_) fault_listener_(applied_.back());
}

void AirframeRig::levelNow() {
  advanceTo(board_.timeS());
  if (plant::Seesaw* s = seesaw()) {
    s->setAngle(0.0, 0.0);
    return;
  }
  plant::Gimbal* g = gimbal();
  const double yaw_rad = truth().yaw_deg * M_PI / 180.0;  // keep the heading: a turn about z only
  g->setState({std::cos(yaw_rad / 2), 0.0, 0.0, std::sin(yaw_rad / 2)}, {0.0, 0.0, 0.0});
}

void AirframeRig::logRow() {
  AirSample s;
  s.truth = rig_->truth();
  s.truth.t_s += t0_s_;
  s.motors = rig_->motors();
  for (int i = 0; i < s.motors; ++i) {
    s.thrust_g[i] = rig_->actuator(i).thrust_g();
    s.rpm[i] = rig_->actuator(i).rpm();
    s.pulse_us[i] = board_.escPulseUs(i);
  }
  s.bus_v = rig_->busVoltage_v();
  if (o_.log_in_memory) samples_.push_back(s);
  if (sample_listener_) sample_listener_(s);
}

std::string AirframeRig::csvHeader(int motors) {
  std::string h = "t_s,roll_deg,pitch_deg,yaw_deg,rate_x_dps,rate_y_dps,rate_z_dps,"
                  "accel_x_g,accel_y_g,accel_z_g";
  for (const char* what : {"force{}_g", "pulse{}_us", "rpm{}"})
    for (int i = 0; i < motors; ++i) h += "," + fmt::format(fmt::runtime(what), i);
  return h + ",bus_v";
}

std::string AirframeRig::csvRow(const AirSample& s) {
  const plant::RigTruth& t = s.truth;
  std::string r = fmt::format("{:.4f},{:.4f},{:.4f},{:.4f},{:.3f},{:.3f},{:.3f},{:.4f},{:.4f},{:.4f}", t.t_s,
                              t.roll_deg, t.pitch_deg, t.yaw_deg, t.rate_dps[0], t.rate_dps[1],
                              t.rate_dps[2], t.specific_force_g[0], t.specific_force_g[1],
                              t.specific_force_g[2]);
  for (int i = 0; i < s.motors; ++i) r += fmt::format(",{:.2f}", s.thrust_g[i]);
  for (int i = 0; i < s.motors; ++i) r += fmt::format(",{:.1f}", s.pulse_us[i]);
  for (int i = 0; i < s.motors; ++i) r += fmt::format(",{:.0f}", s.rpm[i]);
  return r + fmt::format(",{:.3f}", s.bus_v);
}

std::string AirframeRig::describe() const {
  std::string rig;
  if (o_.rig == AirRig::kSeesaw) {
    const auto* s = dynamic_cast<const plant::Seesaw*>(rig_.get());
    rig = fmt::format("seesaw (arm {:.3f} m, I {:.5f} kg m^2, period {:.3f} s, stops +-{:g} deg)",
                      o_.seesaw.arm_m, s->inertia_kgm2(), s->smallOscillationPeriod_s(), o_.seesaw.stop_deg);
  } else {
    const auto& g = o_.gimbal;
    rig = fmt::format("gimbal ({}, arm {:.3f} m, I {:g}/{:g}/{:g} kg m^2)", plant::layoutName(g.layout),
                      g.arm_m, g.inertia_kgm2[0], g.inertia_kgm2[1], g.inertia_kgm2[2]);
  }
  std::string motors;
  for (int i = 0; i < rig_->motors(); ++i)
    motors += fmt::format("{}{} {}", i ? ", " : "", rig_->actuator(i).params().name, rig_->mount(i).spin > 0 ? "CCW" : "CW");
  const bool turned = o_.imu_mount.yaw_deg != 0 || o_.imu_mount.flipped;
  const std::string imu =
      o_.imu ? fmt::format("MPU-6050 at 0x{:02X} seed {}{}{}", o_.imu_params.address, o_.imu_params.seed,
                           o_.imu_params.unit_errors ? "" : " (ideal)",
                           turned ? ", mounted " + imuMountName(o_.imu_mount) : std::string())
             : std::string("no IMU");
  std::string pins;
  const auto table = boardEscPins();
  for (int i = 0; i < rig_->motors(); ++i)
    if (o_.esc_pins[i].port != table[i].port || o_.esc_pins[i].bit != table[i].bit)
      pins = "; ESC pins";
  if (!pins.empty())
    for (int i = 0; i < rig_->motors(); ++i) pins += " " + megaPinName(o_.esc_pins[i]);
  return fmt::format("{}; motors {}; {}{}", rig, motors, imu, pins);
}

}  // namespace sim

// The attitude rigs against hand calculations: the seesaw's inertia, small-oscillation period,
// free-decay damping and end stops; the gimbal's angular acceleration under a torque step,
// torque-free precession (gyroscopic coupling), yaw from the propellers' drag, plus and X
// arms; the IMU's specific force; motor faults. Plant only (no simavr): fast.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "plant/gimbal.hpp"
#include "plant/params.hpp"
#include "plant/seesaw.hpp"

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kG = 9.80665;

plant::ActuatorParams motor() { return plant::presetParams("kv1100_9x4.7"); }

plant::Seesaw benchSeesaw(double damping) {
  plant::SeesawParams p = plant::SeesawParams::benchRig();
  p.pivot_damping_nms_per_rad = damping;
  return plant::Seesaw(p, {motor(), motor()});
}

// Times the swing crosses zero going up, by linear interpolation between sub-steps.
std::vector<double> upwardZeroCrossings(plant::Seesaw& s, double duration_s) {
  std::vector<double> t;
  double prev = s.angle_rad();
  const double h = 0.25e-3;
  for (double time = 0; time < duration_s; time += h) {
    s.step(h);
    const double now = s.angle_rad();
    if (prev < 0 && now >= 0) t.push_back(s.time_s() - h * now / (now - prev));
    prev = now;
  }
  return t;
}

// By hand, from the bench rig's parts: beam 0.120 kg x 0.5^2 / 12; board 0.045 kg at z 0.03;
// ballast 0.200 kg at z -0.10; per side a 68 g motor at (0.225, 0.02) and an 11 g propeller at
// (0.225, 0.05). I = 0.012649 kg m^2, S_z = -0.014830 kg m: T = 2 pi sqrt(I / (g |S_z|)) = 1.853 s.
constexpr double kHandInertia = 0.120 * 0.25 / 12 + 0.045 * 0.03 * 0.03 + 0.200 * 0.01 +
                                2 * (0.068 * (0.225 * 0.225 + 0.02 * 0.02) + 0.011 * (0.225 * 0.225 + 0.05 * 0.05));
constexpr double kHandSz = 0.045 * 0.03 - 0.200 * 0.10 + 2 * (0.068 * 0.02 + 0.011 * 0.05);

TEST(Seesaw, InertiaAndMassMomentAreTheSumOfTheNamedParts) {
  const plant::Seesaw s = benchSeesaw(0.0);
  EXPECT_NEAR(kHandInertia, 0.012649, 1e-6);
  EXPECT_NEAR(kHandSz, -0.014830, 1e-6);
  EXPECT_NEAR(s.inertia_kgm2(), kHandInertia, 1e-12);
  EXPECT_NEAR(s.massMomentZ_kgm(), kHandSz, 1e-12);
  EXPECT_NEAR(s.massMomentY_kgm(), 0.0, 1e-12);
  EXPECT_EQ(s.parts().size(), 7u);
}

TEST(Seesaw, SmallOscillationPeriodIsTwoPiRootOfInertiaOverWeightTimesDrop) {
  plant::Seesaw s = benchSeesaw(0.0);
  const double hand_s = 2 * kPi * std::sqrt(kHandInertia / (kG * -kHandSz));
  s.setAngle(2.0 * kPi / 180.0);
  const auto up = upwardZeroCrossings(s, 12.0);
  ASSERT_GE(up.size(), 5u);
  const double period = (up.back() - up.front()) / static_cast<double>(up.size() - 1);
  EXPECT_NEAR(period, hand_s, hand_s * 0.002);
  EXPECT_NEAR(s.smallOscillationPeriod_s(), hand_s, hand_s * 1e-4);
  RecordProperty("seesaw_period_s", std::to_string(period));
}

TEST(Seesaw, FreeDecayGivesTheDampingRatioOfThePivot) {
  const double c = 0.004;
  plant::Seesaw s = benchSeesaw(c);
  const double k = -kG * s.massMomentZ_kgm();
  const double zeta_hand = c / (2 * std::sqrt(s.inertia_kgm2() * k));
  s.setAngle(3.0 * kPi / 180.0);
  // peaks of the swing
  std::vector<double> peaks;
  double prev_rate = s.rate_rad_s();
  for (int i = 0; i < static_cast<int>(15.0 / 0.25e-3); ++i) {
    s.step(0.25e-3);
    if (prev_rate > 0 && s.rate_rad_s() <= 0) peaks.push_back(s.angle_rad());
    prev_rate = s.rate_rad_s();
  }
  ASSERT_GE(peaks.size(), 4u);
  const double n = static_cast<double>(peaks.size() - 1);
  const double delta = std::log(peaks.front() / peaks.back()) / n;  // log decrement
  const double zeta = delta / std::sqrt(4 * kPi * kPi + delta * delta);
  EXPECT_NEAR(zeta, zeta_hand, zeta_hand * 0.03);
}

TEST(Seesaw, EndStopsBounceTheBeamBackWithItsRestitution) {
  plant::Seesaw s = benchSeesaw(0.0);
  s.setAngle(24.0 * kPi / 180.0, 2.0);
  double max_deg = 0, rate_before = 0;
  for (int i = 0; i < 400; ++i) {
    const double r = s.rate_rad_s();
    s.step(0.25e-3);
    max_deg = std::max(max_deg, s.angle_rad() * 180 / kPi);
    if (r > 0 && s.rate_rad_s() < 0 && rate_before == 0) {
      rate_before = r;
      EXPECT_NEAR(s.rate_rad_s(), -0.3 * r, 0.3 * std::abs(r) * 0.01);
    }
  }
  EXPECT_LE(max_deg, 25.0 + 1e-9);
  EXPECT_GT(rate_before, 0.0) << "the beam never reached the stop";
}

TEST(Seesaw, MoreThrustOnTheLeftMotorLiftsTheLeftSide) {
  plant::Seesaw s = benchSeesaw(0.004);
  s.holdPulse(0, 1400);
  s.holdPulse(1, 1300);
  s.step(0.5);
  EXPECT_GT(s.truth().roll_deg, 1.0);
  EXPECT_GT(s.truth().motor_torque_nm[0], 0.0);
}

plant::Gimbal quietGimbal(plant::Layout layout = plant::Layout::kX) {
  plant::GimbalParams p;
  p.layout = layout;
  p.damping_nms_per_rad = {0, 0, 0};
  return plant::Gimbal(p, {motor(), motor(), motor(), motor()});
}

TEST(Gimbal, ATorqueStepAcceleratesEachAxisAtTorqueOverInertia) {
  const double inertia[3] = {0.018, 0.018, 0.032};
  for (int axis = 0; axis < 3; ++axis) {
    plant::Gimbal g = quietGimbal();
    std::array<double, 3> tau{};
    tau[axis] = 0.05;
    g.setDisturbanceTorque(tau);
    g.step(0.2);
    const plant::RigTruth t = g.truth();
    const double alpha = 0.05 / inertia[axis];  // rad/s^2, by hand
    EXPECT_NEAR(t.rate_dps[axis], alpha * 0.2 * 180 / kPi, 1e-6) << "axis " << axis;
    EXPECT_NEAR(t.accel_dps2[axis], alpha * 180 / kPi, 1e-6) << "axis " << axis;
    const double angle_deg = 0.5 * alpha * 0.2 * 0.2 * 180 / kPi;  // 3.18 deg about x and y
    const double got = axis == 0 ? t.roll_deg : axis == 1 ? t.pitch_deg : t.yaw_deg;
    EXPECT_NEAR(got, angle_deg, angle_deg * 1e-4) << "axis " << axis;
  }
}

TEST(Gimbal, ASpinningAirframePrecessesAtTheEulerRate) {
  // Torque-free, symmetric (Ixx = Iyy): a small x rate turns about z at
  // lambda = Omega (Izz - Ixx) / Ixx in the body, |w| and the energy stay.
  plant::Gimbal g = quietGimbal();
  const double omega = 10.0, wx = 0.1;
  g.setState({1, 0, 0, 0}, {wx, 0.0, omega});
  const double lambda = omega * (0.032 - 0.018) / 0.018;
  const double energy0 = 0.5 * (0.018 * wx * wx + 0.032 * omega * omega);
  g.step(kPi / lambda);  // half a precession period
  const auto t = g.truth();
  const double w[3] = {t.rate_dps[0] * kPi / 180, t.rate_dps[1] * kPi / 180, t.rate_dps[2] * kPi / 180};
  EXPECT_NEAR(w[0], -wx, 1e-5);
  EXPECT_NEAR(w[1], 0.0, 1e-5);
  EXPECT_NEAR(w[2], omega, 1e-9);
  const double energy = 0.5 * (0.018 * (w[0] * w[0] + w[1] * w[1]) + 0.032 * w[2] * w[2]);
  EXPECT_NEAR(energy, energy0, energy0 * 1e-9);
}

TEST(Gimbal, EqualMotorsMakeNoTorqueAndTheCcwPairYawsTheFrameClockwise) {
  plant::Gimbal g = quietGimbal();
  for (int i = 0; i < 4; ++i) g.holdPulse(i, 1450);
  g.step(1.0);
  auto t = g.truth();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(t.motor_torque_nm[k], 0.0, 1e-9) << k;
  // when: the counter-clockwise pair (0, 2) runs faster
  g.holdPulse(0, 1550);
  g.holdPulse(2, 1550);
  g.step(1.0);
  t = g.truth();
  const double q_ccw = g.actuator(0).torque_nm() + g.actuator(2).torque_nm();
  const double q_cw = g.actuator(1).torque_nm() + g.actuator(3).torque_nm();
  EXPECT_NEAR(t.motor_torque_nm[2], q_cw - q_ccw, std::abs(q_cw - q_ccw) * 0.01);  // steady: no spin-up term
  EXPECT_LT(t.motor_torque_nm[2], 0.0);
  EXPECT_LT(t.rate_dps[2], 0.0);
  EXPECT_NEAR(t.motor_torque_nm[0], 0.0, 1e-9);  // 0 and 2 are diagonal: no roll, no pitch
  EXPECT_NEAR(t.motor_torque_nm[1], 0.0, 1e-9);
}

TEST(Gimbal, ASpinPerMotorReplacesTheLayoutsAndTurnsTheYawTorqueAround) {
  // given: the X layout's spins reversed (MultiWii's QUADX: front-left and rear-right clockwise)
  plant::GimbalParams p;
  p.damping_nms_per_rad = {0, 0, 0};
  p.common.spin = {-1, 1, -1, 1};
  plant::Gimbal g(p, {motor(), motor(), motor(), motor()});
  for (int i = 0; i < 4; ++i) EXPECT_EQ(g.mount(i).spin, p.common.spin[i]) << i;
  for (int i = 0; i < 4; ++i) g.holdPulse(i, 1450);
  // when: motors 0 and 2, now the clockwise pair, run faster
  g.holdPulse(0, 1550);
  g.holdPulse(2, 1550);
  g.step(2.0);
  const auto t = g.truth();
  const double q_cw = g.actuator(0).torque_nm() + g.actuator(2).torque_nm();
  const double q_ccw = g.actuator(1).torque_nm() + g.actuator(3).torque_nm();
  // then: the reaction turns the frame counter-clockwise, as much as the layout's turned it clockwise
  EXPECT_NEAR(t.motor_torque_nm[2], q_cw - q_ccw, std::abs(q_cw - q_ccw) * 0.01);
  EXPECT_GT(t.motor_torque_nm[2], 0.0);
  EXPECT_GT(t.rate_dps[2], 0.0);
}

TEST(Gimbal, WithoutReactionTorqueTheMotorsPushWithThrustAlone) {
  // given: the diagnostic rig (no drag or spin-up torque on the body) and the default one
  plant::GimbalParams p;
  p.damping_nms_per_rad = {0, 0, 0};
  p.common.reaction_torque = false;
  plant::Gimbal bare(p, {motor(), motor(), motor(), motor()});
  plant::Gimbal real = quietGimbal();
  for (plant::Gimbal* g : {&bare, &real}) {
    for (int i = 0; i < 4; ++i) g->holdPulse(i, 1450);
    g->step(0.5);
    // when: the counter-clockwise pair spins up and motor 1 speeds up against motor 3 (a roll)
    g->holdPulse(0, 1550);
    g->holdPulse(2, 1550);
    g->holdPulse(1, 1500);
    g->step(0.2);
  }
  const auto b = bare.truth(), r = real.truth();
  // then: no yaw torque and no yaw on the diagnostic rig, the same roll torque as the real one's
  EXPECT_EQ(b.motor_torque_nm[2], 0.0);
  EXPECT_NEAR(b.rate_dps[2], 0.0, 1e-9);
  EXPECT_LT(r.motor_torque_nm[2], -1e-3);
  EXPECT_NEAR(b.motor_torque_nm[0], r.motor_torque_nm[0], 1e-9);
  EXPECT_GT(std::abs(b.motor_torque_nm[0]), 0.01);
}

TEST(Gimbal, ASpinListOfTheWrongLengthOrValueIsRefused) {
  plant::GimbalParams p;
  p.common.spin = {1, -1, 1};
  EXPECT_THROW(plant::Gimbal(p, {motor(), motor(), motor(), motor()}), std::invalid_argument);
  p.common.spin = {1, -1, 1, 0};
  EXPECT_THROW(plant::Gimbal(p, {motor(), motor(), motor(), motor()}), std::invalid_argument);
}

TEST(Gimbal, PlusAndXLayoutsPutTheMotorsOnTheirArms) {
  for (auto layout : {plant::Layout::kPlus, plant::Layout::kX}) {
    plant::Gimbal g = quietGimbal(layout);
    g.holdPulse(1, 1500);  // plus: the left motor; X: rear-left
    g.step(0.2);
    const double f = g.actuator(1).thrust_n();
    const auto t = g.truth();
    const double arm = layout == plant::Layout::kPlus ? 0.225 : 0.225 / std::sqrt(2.0);
    EXPECT_NEAR(t.motor_torque_nm[0], arm * f, 1e-9) << plant::layoutName(layout);
    EXPECT_NEAR(t.motor_torque_nm[1], layout == plant::Layout::kPlus ? 0.0 : arm * f, 1e-9);
    EXPECT_GT(t.rate_dps[0], 0.0);
  }
}

TEST(Gimbal, MotorTorqueStepResponseFollowsTheMotorsTimeConstant) {
  plant::Gimbal g = quietGimbal();
  for (int i = 0; i < 4; ++i) g.holdPulse(i, 1450);
  g.step(1.5);
  g.setState({1, 0, 0, 0}, {0, 0, 0});
  // when: the left pair (0, 1) steps up 50 us
  g.holdPulse(0, 1500);
  g.holdPulse(1, 1500);
  double t63 = -1;
  const double dt = 0.25e-3;
  std::vector<double> tau;
  for (int i = 0; i < 2000; ++i) {
    g.step(dt);
    tau.push_back(g.truth().motor_torque_nm[0]);
    const auto t = g.truth();
    // Euler: about x the angular acceleration is the torque over Ixx (small rates)
    EXPECT_NEAR(t.accel_dps2[0] * kPi / 180, t.motor_torque_nm[0] / 0.018, 0.05) << i;
  }
  for (std::size_t i = 0; i < tau.size(); ++i)
    if (tau[i] >= 0.632 * tau.back()) {
      t63 = (i + 1) * dt;
      break;
    }
  EXPECT_GT(t63, 0.04);  // the motors' speed time constant, ~0.05..0.12 s (plant fidelity)
  EXPECT_LT(t63, 0.12);
  RecordProperty("torque_t63_s", std::to_string(t63));
}

TEST(Rig, ImuAtRestReadsGravityInBodyAxesAndCentripetalOffThePivot) {
  plant::Seesaw s = benchSeesaw(0.0);
  s.setAngle(30.0 * kPi / 180.0, 0.0);
  auto f = s.truth().specific_force_g;
  EXPECT_NEAR(f[1], std::sin(30.0 * kPi / 180.0), 1e-12);  // left side up: +y sees up
  // the board's IMU sits 3 cm above the pivot: a swing through level adds -w^2 r on z
  s.setAngle(0.0, 2.0);
  f = s.truth().specific_force_g;
  EXPECT_NEAR(f[2], 1.0 - 2.0 * 2.0 * 0.03 / kG, 1e-12);
}

TEST(Rig, OneMillisecondStepIsFourQuarterMillisecondSubsteps) {
  plant::Gimbal a = quietGimbal(), b = quietGimbal();
  for (int i = 0; i < 4; ++i) {
    a.holdPulse(i, 1300 + 50 * i);
    b.holdPulse(i, 1300 + 50 * i);
  }
  for (int i = 0; i < 200; ++i) {
    a.step(1e-3);
    for (int k = 0; k < 4; ++k) b.step(0.25e-3);
  }
  EXPECT_EQ(a.truth().q_wxyz, b.truth().q_wxyz);
  EXPECT_EQ(a.truth().rate_dps, b.truth().rate_dps);
}

TEST(Rig, ADeadMotorCoastsDownAndIgnoresPulsesALosingPropellerPushesLess) {
  plant::Gimbal g = quietGimbal();
  for (int i = 0; i < 4; ++i) g.holdPulse(i, 1450);
  g.step(1.0);
  const double rpm = g.actuator(0).rpm();
  g.killMotor(0);
  g.loseThrust(1, 0.3);
  g.setPulse(0, 1900, g.time_s());
  g.step(1.0);
  EXPECT_LT(g.actuator(0).rpm(), 0.4 * rpm);  // drag only: slow at the end (spin-down ~0.24 s at first)
  EXPECT_TRUE(g.motorDead(0));
  // same pulse, 30 % less thrust at a given speed; the lighter load spins it a little faster
  const double ratio = g.actuator(1).thrust_n() / g.actuator(2).thrust_n();
  EXPECT_GT(ratio, 0.7);
  EXPECT_LT(ratio, 0.85);
  EXPECT_GT(g.actuator(1).rpm(), g.actuator(2).rpm());
}

TEST(Rig, RotorImbalanceShakesTheImuAtTheRotorFrequency) {
  plant::GimbalParams p;
  p.common.vibration_g_at_10krpm = 0.5;
  plant::Gimbal g(p, {motor(), motor(), motor(), motor()});
  g.holdPulse(0, 1500);
  g.step(1.0);
  const double s = g.actuator(0).rpm() / 10000.0;
  double sum2 = 0;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    g.step(0.25e-3);
    const auto t = g.truth();
    const auto& q = t.q_wxyz;  // minus gravity's share on x (the lone motor tilts the frame)
    const double vib = t.specific_force_g[0] - 2 * (q[1] * q[3] - q[0] * q[2]);
    sum2 += vib * vib;
  }
  EXPECT_NEAR(std::sqrt(sum2 / n), 0.5 * s * s / std::sqrt(2.0), 0.5 * s * s * 0.05);
}

}  // namespace

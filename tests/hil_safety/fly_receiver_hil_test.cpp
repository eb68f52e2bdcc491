// Issue 27 item 1: fly's receiver in simavr. The real fly.elf on the virtual airframe (the
// gimbal, pwm mode: no calibrated slot needed) with the simulator's RC receiver on its pins
// (sim/rc_input.hpp, as `sim console --rc`): a PPM sum on A8, and one pulse per channel on
// A8..A12 (port K's pin-change interrupt). One simulation per test, each assertion at its stage:
//  - out-of-range pulses and 20 us spikes on the wire are rejected and counted in `status`, and
//    neither arm nor move anything;
//  - stick arming (throttle low, yaw right) arms 1 s after the gesture's first frame, never
//    before, and only when the other arming checks pass (force mode without records: refused);
//  - the sticks fly: a roll (PPM) or pitch (PWM) stick tilts the gimbal by the angle angle mode
//    gives that stick, with its sign; the mode switch (channel 5) gives rate mode;
//  - stick disarm (throttle low, yaw left) stops every pulse; off level, arming is refused; the
//    rig set level again (issue 27 item 4), the sticks arm and fly again in the same simulation;
//  - a dropout of one receiver frame is ridden through; `loss` in the RC script stops every ESC
//    pulse within 100 ms of the last valid frame, measured on the ESC pins' edges and the
//    receiver's own edges, in simulated time.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "safety_support.hpp"
#include "sim/airframe.hpp"
#include "sim/ports.hpp"
#include "sim/rc_input.hpp"

extern "C" {
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_irq.h>

#include "text_match.hpp"
}

namespace {

constexpr double kStopUs = 1005.0;    // at or below: the stop pulse (1000 us + a tick)
constexpr double kHoldS = 1.0;        // fly's kStickHoldMs: a gesture held this long acts
constexpr double kFailsafeS = 0.100;  // the target: pulses stop within this of the last valid frame
constexpr double kFullAngleDeg = 30;  // angle mode: full roll or pitch stick (default `rates`)
constexpr double kFullRateDps = 200;  // rate mode: full roll or pitch stick

// A stick `us` from the centre, as angle mode flies it (rc_input.cpp: 10 us dead band, the
// remaining 490 us are the full angle).
double angleOfStickDeg(double us_from_centre) { return (us_from_centre - 10) / 490 * kFullAngleDeg; }

struct RcEdge {
  int line;
  int level;
  double t_s;
};

class FlyReceiverHil : public ::testing::Test {
 protected:
  // fly booted on the gimbal with the receiver on `rc_spec`, sending the sticks at rest (AETR,
  // throttle low, channel 5 low: angle mode), `rc_command` given, ESCs past their first 2 s.
  void boot(const std::string& rc_spec, const std::string& rc_command) {
    sim::AirframeOptions o;
    o.imu_params.seed = 7;
    o.log_period_s = 0.005;
    rig_ = std::make_unique<sim::AirframeRig>(hil::imagePath("fly"), o);
    rc_ = std::make_unique<sim::RcOnBoard>(rig_->board(), sim::parseRcSpec(rc_spec, &o.esc_pins));
    for (int line = 0; line < rc_->part().lines; ++line)
      avr_irq_register_notify(rc_->part().irq + line, &FlyReceiverHil::onRcEdge, this);
    pulses_ = std::make_unique<safety::PulseLog>(rig_->board());
    con_ = std::make_unique<sim::Console>(rig_->board(), "fly> ");
    con_->onLine([this](const std::string& line) {  // a note fly prints unasked follows a prompt
      const bool prompted = line.rfind("fly> ", 0) == 0;
      lines_.push_back({rig_->board().timeS(), prompted ? line.substr(5) : line});
    });
    sticks(1500, 1500, 1000, 1500);
    con_->expectText("imu: gyro bias", 5.0);
    con_->waitPrompt(1.0);
    const auto rc = con_->command(rc_command);
    ASSERT_FALSE(rc.empty());
    ASSERT_EQ(rc[0].rfind("rc: ", 0), 0u) << con_->tail();
    while (rig_->truth().t_s < 2.1) rig_->run(0.1);  // the ESCs' 2 s at the stop pulse
  }
  void TearDown() override {
    if (con_) con_->clearLineListeners();
  }

  // Throttle low and yaw right: armed 1 s after the gesture was set, not before (measured on the
  // ESC pins: the gesture's first frame comes within a frame, is decoded by the next one's start
  // at the latest, and is checked at each frame after: at most three 22.5 ms frames on top).
  void armFromTheSticks(const char* receiver) {
    const double gesture_s = now();
    sticks(1500, 1500, 1000, 2000);
    awaitNote("armed: mode pwm, layout x, from the sticks", kHoldS + 0.2);
    const double spins_s = firstSpinning(gesture_s);
    ASSERT_GT(spins_s, 0) << con_->tail();
    std::printf("%s: the first pulse above the stop pulse ended %.1f ms after the gesture was set\n", receiver,
                (spins_s - gesture_s) * 1000);
    EXPECT_GE(spins_s - gesture_s, kHoldS) << "a motor spun before the gesture was held 1 s";
    EXPECT_LE(spins_s - gesture_s, kHoldS + 0.070);
  }

  // The transmitter's sticks from the receiver's next frame on (channel 5: the mode switch).
  void sticks(double roll, double pitch, double throttle, double yaw, double mode = 1000) {
    const std::string reply = rc_->command(fmt::format("ch {} {} {} {} {}", roll, pitch, throttle, yaw, mode));
    ASSERT_EQ(reply.rfind("ok", 0), 0u) << reply;
  }
  void run(double s) { rig_->run(s); }
  double now() { return rig_->board().timeS(); }

  // When fly printed a line starting with `start` at or after `from_s` (-1: never).
  double saidAt(const std::string& start, double from_s) const {
    for (const auto& l : lines_)
      if (l.first >= from_s && l.second.rfind(start, 0) == 0) return l.first;
    return -1;
  }
  // Waits for a note fly prints unasked (an arm, a refusal, a disarm) and the prompt after it,
  // so the next command's reply is its own.
  void awaitNote(const std::string& text, double budget_s) {
    con_->expectText(text, budget_s);
    con_->waitPrompt(0.1);
  }

  // The widest ESC pulse that ended in [from_s, to_s).
  double widest(double from_s, double to_s) const { return pulses_->widestBetween(from_s, to_s); }
  // The end of the last pulse above the stop pulse; the end of the first one after `from_s`.
  double lastSpinning() const { return pulses_->lastWiderThan(kStopUs); }
  double firstSpinning(double from_s) const {
    for (const sim::Pulse& p : pulses_->pulses())
      if (p.end_s >= from_s && p.width_us > kStopUs) return p.end_s;
    return -1;
  }
  // The rig's mean attitude over [from_s, to_s).
  double meanDeg(double from_s, double to_s, double plant::RigTruth::*field) const {
    double sum = 0;
    int n = 0;
    for (const sim::AirSample& s : rig_->samples())
      if (s.truth.t_s >= from_s && s.truth.t_s < to_s) sum += s.truth.*field, ++n;
    return n ? sum / n : NAN;
  }

  double meanRollRateDps(double from_s, double to_s) const {
    double sum = 0;
    int n = 0;
    for (const sim::AirSample& s : rig_->samples())
      if (s.truth.t_s >= from_s && s.truth.t_s < to_s) sum += s.truth.rate_dps[0], ++n;
    return n ? sum / n : NAN;
  }

  struct Receiver {
    long frames = -1, rejected = -1, bad = -1, lost = -1, failsafes = -1;
    std::string sticks;
  };
  // `status`'s receiver line.
  Receiver status() {
    Receiver r;
    static const tc::test::Pattern re(
        "receiver: frames (\\d+), last \\d+ ms ago, rejected pulses (\\d+), bad frames (\\d+), lost edges "
        "(\\d+), failsafes (\\d+); (sticks .*)");
    for (const std::string& line : con_->command("status")) {
      tc::test::Groups m;
      if (!re.foundIn(line, &m)) continue;
      r.frames = std::stol(m[1]);
      r.rejected = std::stol(m[2]);
      r.bad = std::stol(m[3]);
      r.lost = std::stol(m[4]);
      r.failsafes = std::stol(m[5]);
      r.sticks = m[6];
    }
    return r;
  }

  // The receiver's last edge (its signal's end) and the end of its last complete frame: PPM,
  // the falling edge that ends a sync gap (a decoder knows a frame is whole there); PWM, the
  // last wired channel's falling edge.
  double longestRcSilence(double from_s) const {
    double longest = 0, prev = -1;
    for (const RcEdge& e : rc_edges_) {  // a silence that began before from_s counts whole
      if (e.t_s >= from_s && prev >= 0) longest = std::max(longest, e.t_s - prev);
      prev = e.t_s;
    }
    return longest;
  }
  double lastRcEdge() const { return rc_edges_.empty() ? -1 : rc_edges_.back().t_s; }
  double lastCompleteFrame() const {
    const int last_line = rc_->part().lines - 1;
    double prev_fall = -1, found = -1;
    for (const RcEdge& e : rc_edges_) {
      if (e.level != 0 || e.line != last_line) continue;
      if (rc_->part().signal == sim::RcSignal::kPwm) found = e.t_s;
      if (rc_->part().signal == sim::RcSignal::kPpm && prev_fall >= 0 && e.t_s - prev_fall > 0.0027)
        found = e.t_s;
      prev_fall = e.t_s;
    }
    return found;
  }

  // `loss` in an RC script, `after_s` from now; runs 0.3 s. Returns the last valid frame's end.
  void loseTheSignal(double after_s = 0.05) {
    rc_->play(sim::parseRcScript(fmt::format("t_s,ch1\n{:.6f},loss\n", now() + after_s), "loss.csv"));
    run(after_s + 0.3);
  }

  // The receiver sends no signal in the next `frames` frames, then the sticks again.
  void dropFrames(int frames) {
    const sim::RcPart& p = rc_->part();
    const double frame_s = sim::cyclesToSeconds(p.frame_cycles);
    // the first frame that starts after now (with a margin for the script's row before it):
    // the frame under way when this is called may be about to end
    double next_s = sim::cyclesToSeconds(p.frame_start + p.frame_cycles);
    while (next_s - 0.002 < rig_->board().timeS()) next_s += frame_s;
    rc_->play(sim::parseRcScript(fmt::format("t_s,ch1,ch2,ch3,ch4,ch5\n{:.6f},loss\n{:.6f},1500,1500,1500,1500,1000\n",
                                             next_s - 0.001, next_s + (frames - 1) * frame_s + 0.001),
                                 "dropout.csv"));
  }

  // Noise on the wire: receiver line `line` flips for `width_us` at `offset_us` into each of the
  // receiver's next `frames` frames, then goes back (a spike coupled into a long lead). The
  // offset must fall where the line holds still for longer than the spike.
  void spikes(int line, double offset_us, int frames, double width_us = 20) {
    const sim::RcPart& p = rc_->part();
    for (int k = 0; k < frames; ++k) {
      auto spike = std::make_unique<Spike>();
      spike->self = this;
      spike->line = line;
      spike->width = static_cast<uint64_t>(width_us * 16);
      const uint64_t at = p.frame_start + (k + 1) * p.frame_cycles + static_cast<uint64_t>(offset_us * 16);
      avr_cycle_timer_register(p.avr, at - p.avr->cycle, &FlyReceiverHil::onSpike, spike.get());
      spikes_.push_back(std::move(spike));
    }
  }

  std::unique_ptr<sim::AirframeRig> rig_;
  std::unique_ptr<sim::RcOnBoard> rc_;
  std::unique_ptr<safety::PulseLog> pulses_;
  std::unique_ptr<sim::Console> con_;
  std::vector<std::pair<double, std::string>> lines_;
  std::vector<RcEdge> rc_edges_;

 private:
  struct Spike {
    FlyReceiverHil* self = nullptr;
    int line = 0;
    uint64_t width = 0;  // cycles
    bool on = false;
  };
  std::vector<std::unique_ptr<Spike>> spikes_;
  static avr_cycle_count_t onSpike(avr_t* avr, avr_cycle_count_t when, void* param) {
    auto* sp = static_cast<Spike*>(param);
    const sim::RcPart& p = sp->self->rc_->part();
    const hal::MegaPin pin = p.pins[sp->line];
    const bool level = p.level[sp->line] != 0;  // what the receiver holds the line at
    sp->on = !sp->on;
    p.ports->setInput(pin.port, pin.bit, sp->on ? !level : level, when);
    (void)avr;
    return sp->on ? when + sp->width : 0;
  }
  static void onRcEdge(avr_irq_t* irq, uint32_t value, void* param) {
    auto* self = static_cast<FlyReceiverHil*>(param);
    self->rc_edges_.push_back({static_cast<int>(irq - self->rc_->part().irq), value ? 1 : 0, self->now()});
  }
};

TEST_F(FlyReceiverHil, APpmSumOnA8ArmsFromTheSticksFliesTheRollStickAndStopsOnLoss) {
  HIL_REQUIRE_IMAGE("fly");
  boot("ppm:A8", "rc ppm");
  const Receiver at_rest = status();
  EXPECT_GT(at_rest.frames, 20) << con_->tail();
  EXPECT_EQ(at_rest.rejected, 0);
  EXPECT_EQ(at_rest.bad, 0);

  // the arming gesture in force mode, no slot calibrated: behind every check `arm` has
  sticks(1500, 1500, 1000, 2000);
  awaitNote("sticks: error: arm refused: ", kHoldS + 0.1);
  EXPECT_LT(widest(0, now()), kStopUs);
  sticks(1500, 1500, 1000, 1500);
  run(0.1);
  con_->command("mode pwm");
  con_->command("hover 1480 1440");

  // the gesture with an out-of-range pitch channel: every frame rejected, counted, not flown
  sticks(1500, 2400, 1000, 2000);
  const double noise_s = now();
  run(kHoldS + 0.2);
  // valid sticks again for a frame before reading the counters: a frame under way has its
  // rejected pulse counted but is not yet judged bad
  sticks(1500, 1500, 1000, 1500);
  run(0.05);
  const Receiver noisy = status();
  EXPECT_GE(noisy.bad - at_rest.bad, 50) << "one bad frame per 22.5 ms";
  EXPECT_EQ(noisy.rejected - at_rest.rejected, noisy.bad - at_rest.bad) << "one rejected pulse per frame";
  // the valid frame's sticks: centred (within the dead band) and the throttle at 1000 us to
  // within the edge timestamps' jitter (taken in the pin-change interrupt, a few microseconds
  // later when another interrupt runs at the edge)
  tc::test::Groups stick;
  ASSERT_TRUE(tc::test::Pattern("sticks roll 0 pitch 0 yaw 0 us, throttle (\\d+) us, angle mode")
                  .matches(noisy.sticks, &stick))
      << noisy.sticks;
  EXPECT_NEAR(std::stoi(stick[1]), 1000, 2) << noisy.sticks;
  EXPECT_LT(saidAt("armed:", noise_s), 0) << "noise armed it";
  EXPECT_LT(widest(noise_s, now()), kStopUs);

  // the gesture, valid: armed 1 s after it began, not before
  armFromTheSticks("ppm");

  // half throttle, spooled up, level; then noise in flight moves nothing
  sticks(1500, 1500, 1500, 1500);
  run(1.5);
  const double level_roll = meanDeg(now() - 0.3, now(), &plant::RigTruth::roll_deg);
  EXPECT_NEAR(level_roll, 0.0, 3.0);
  const Receiver before_noise = status();
  sticks(2400, 1500, 1500, 1500);  // a roll of +2400 us: out of range, three frames
  run(0.06);
  sticks(1500, 1500, 1500, 1500);
  const double noise_in_flight_s = now();
  run(0.3);
  const Receiver after_noise = status();
  EXPECT_GE(after_noise.bad - before_noise.bad, 2);
  EXPECT_LT(saidAt("disarmed", 0), 0) << con_->tail();
  EXPECT_NEAR(meanDeg(noise_in_flight_s, now(), &plant::RigTruth::roll_deg), level_roll, 1.0)
      << "an out-of-range roll stick moved the gimbal";
  // spikes on the wire, 20 us inside channel 1 of three frames: each splits it in two (one of
  // them too short), so each frame has nine channels: bad, not flown
  spikes(0, 900, 3);
  run(0.1);
  const Receiver spiked = status();
  EXPECT_EQ(spiked.bad - after_noise.bad, 3) << con_->tail();
  EXPECT_GE(spiked.rejected - after_noise.rejected, 3);
  EXPECT_LT(saidAt("disarmed", 0), 0) << con_->tail();

  // a roll stick right: the gimbal rolls right (positive) by the stick's angle
  sticks(1700, 1500, 1500, 1500);
  run(1.5);
  const double rolled = meanDeg(now() - 0.5, now(), &plant::RigTruth::roll_deg) - level_roll;
  std::printf("ppm: +200 us roll stick -> %.2f deg (angle mode asks %.2f)\n", rolled, angleOfStickDeg(200));
  EXPECT_NEAR(rolled, angleOfStickDeg(200), 2.0);

  // a frame lost: a dropout the failsafe rides through
  sticks(1500, 1500, 1500, 1500);
  run(0.3);
  const double dropout_s = now();
  dropFrames(1);
  run(0.3);
  EXPECT_GT(longestRcSilence(dropout_s), 0.030) << "the receiver sent every frame";
  EXPECT_LT(saidAt("disarmed", 0), 0) << "a dropout of one frame disarmed it\n" << con_->tail();

  // the link lost: every pulse stops within 100 ms of the last valid frame
  loseTheSignal();
  awaitNote("disarmed: receiver lost (no valid frame for ", 0.1);
  const double stop_s = lastSpinning();
  std::printf("ppm: last pulse above the stop pulse ended %.1f ms after the last complete frame, "
              "%.1f ms after the receiver's last edge\n",
              (stop_s - lastCompleteFrame()) * 1000, (stop_s - lastRcEdge()) * 1000);
  EXPECT_LE(stop_s - lastCompleteFrame(), kFailsafeS);
  EXPECT_LE(widest(stop_s + 1e-6, now()), 1000.6);
  EXPECT_GT(pulses_->countBetween(stop_s + 0.05, now()), 4 * 50) << "the ESCs keep their stop pulse";
}

// One pulse per channel on A8..A12 (AETR and the mode switch), and the round trip of issue 27
// item 4 from the sticks: armed, flown, disarmed from the sticks, the gimbal drifting off level
// (arming refused), set level again (what `level` on `sim console`'s terminal does), armed
// again and flown again in the same simulation.
TEST_F(FlyReceiverHil, PwmPulsesOnA8ToA12ArmFlyDisarmAndArmAgainAfterTheRigIsLevelled) {
  HIL_REQUIRE_IMAGE("fly");
  boot("pwm:A8,A9,A10,A11,A12", "rc pwm 5");
  con_->command("mode pwm");
  con_->command("hover 1480 1440");
  const Receiver at_rest = status();
  EXPECT_GT(at_rest.frames, 20) << con_->tail();

  // the gesture with an out-of-range pitch pulse: the pulse rejected every frame, no frame
  // complete, nothing armed
  const double noise_s = now();
  sticks(1500, 600, 1000, 2000);
  run(kHoldS + 0.2);
  const Receiver noisy = status();
  EXPECT_GE(noisy.rejected - at_rest.rejected, 50) << "one per 20 ms frame";
  EXPECT_LE(noisy.frames - at_rest.frames, 2) << "frames completed with a pulse rejected";
  EXPECT_LT(saidAt("armed:", noise_s), 0) << "noise armed it";
  EXPECT_LT(widest(noise_s, now()), kStopUs);

  // armed from the sticks after 1 s
  armFromTheSticks("pwm");

  // a pitch stick forward: the nose goes down (positive pitch) by the stick's angle; before it,
  // spikes of 20 us on the pitch pin between its pulses in three frames: rejected and counted
  sticks(1500, 1500, 1500, 1500);
  run(1.3);
  const Receiver before_spikes = status();
  spikes(1, 12000, 3);
  run(0.2);
  const double level_pitch = meanDeg(now() - 0.3, now(), &plant::RigTruth::pitch_deg);
  const Receiver spiked = status();
  EXPECT_EQ(spiked.rejected - before_spikes.rejected, 3) << con_->tail();
  EXPECT_GE(spiked.frames - before_spikes.frames, 8) << "the frames between flew on";
  EXPECT_LT(saidAt("disarmed", 0), 0) << con_->tail();
  sticks(1500, 1700, 1500, 1500);
  run(1.5);
  const double pitched = meanDeg(now() - 0.5, now(), &plant::RigTruth::pitch_deg) - level_pitch;
  std::printf("pwm: +200 us pitch stick -> %.2f deg (angle mode asks %.2f)\n", pitched, angleOfStickDeg(200));
  EXPECT_NEAR(pitched, angleOfStickDeg(200), 2.0);

  // the mode switch high: rate mode, a roll stick is a roll rate
  sticks(1600, 1500, 1500, 1500, 2000);
  run(0.3);
  const double roll_rate = meanRollRateDps(now() - 0.15, now());
  const double asked_dps = (100.0 - 10) / 490 * kFullRateDps;
  std::printf("pwm: rate mode, +100 us roll stick -> %.1f deg/s (rate mode asks %.1f)\n", roll_rate, asked_dps);
  EXPECT_GT(roll_rate, 0.6 * asked_dps) << "P only: the gimbal's friction keeps it a little short";
  EXPECT_LT(roll_rate, 1.1 * asked_dps);

  // disarmed from the sticks: every pulse stops
  const double disarm_s = now();
  sticks(1500, 1500, 1000, 1000);
  awaitNote("disarmed: sticks (throttle low, yaw left)", kHoldS + 0.2);
  const double stopped_s = lastSpinning();
  EXPECT_GE(stopped_s - disarm_s, kHoldS - 0.1) << "disarmed before the gesture was held";
  run(1.0);
  EXPECT_LE(widest(stopped_s + 1e-6, now()), 1000.6);
  sticks(1500, 1500, 1000, 1500);
  run(0.1);
  const plant::RigTruth off = rig_->truth();
  std::printf("pwm: 1 s after the disarm the gimbal is at roll %.1f pitch %.1f deg\n", off.roll_deg, off.pitch_deg);

  // off level, arming is refused; levelled, it arms again from the sticks and flies
  sticks(1500, 1500, 1000, 2000);
  awaitNote("sticks: error: arm refused: not level", kHoldS + 0.2);
  sticks(1500, 1500, 1000, 1500);
  rig_->levelNow();
  const double levelled_s = now();
  run(1.0);
  sticks(1500, 1500, 1000, 2000);
  awaitNote("armed: mode pwm, layout x, from the sticks", kHoldS + 0.2);
  std::printf("pwm: armed again %.2f s after the rig was levelled\n", now() - levelled_s);
  sticks(1500, 1500, 1500, 1500);
  run(1.5);
  const double level_again = meanDeg(now() - 0.3, now(), &plant::RigTruth::pitch_deg);
  EXPECT_NEAR(level_again, level_pitch, 1.0) << "flies level again";
  sticks(1500, 1700, 1500, 1500);
  run(1.5);
  const double pitched_again = meanDeg(now() - 0.5, now(), &plant::RigTruth::pitch_deg) - level_again;
  EXPECT_NEAR(pitched_again, pitched, 0.5) << "the second flight answers the stick as the first";

  // the link lost: every pulse stops within 100 ms of the last valid frame
  sticks(1500, 1500, 1500, 1500);
  run(0.3);
  loseTheSignal();
  awaitNote("disarmed: receiver lost (no valid frame for ", 0.1);
  const double stop_s = lastSpinning();
  std::printf("pwm: last pulse above the stop pulse ended %.1f ms after the last complete frame\n",
              (stop_s - lastCompleteFrame()) * 1000);
  EXPECT_LE(stop_s - lastCompleteFrame(), kFailsafeS);
  EXPECT_LE(widest(stop_s + 1e-6, now()), 1000.6);
  const Receiver end = status();
  EXPECT_EQ(end.failsafes, 1);
}

}  // namespace

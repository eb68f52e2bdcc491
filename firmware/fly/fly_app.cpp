// fly: see fly_app.hpp for the flow and the safety rules. This file is the life cycle:
// start-up, the main loop's pass, the frame (fast path, then one slow job), the failsafes and
// disarming. The commands are in commands.cpp, every printed line in fly_view.cpp.
#include "fly_app.hpp"

#include "fly_view.hpp"
#include "record_report.hpp"
#include "slot_report.hpp"

namespace fly {

FlyApp* FlyApp::active_ = nullptr;

namespace {
constexpr uint16_t kImuStartMaxMs = 1000;
constexpr uint16_t kCalibrationMaxMs = 5000;

// A stream row's numbers from the frame path's own units, integer only (float conversions
// were a third of a row's cost): angle units to centidegrees, rate units to decidegrees per
// second, rounded and saturated to 16 bits.
constexpr Gain kCentidegPerAngleUnit = gainOf(100.0f * kDegPerRad * kRadPerAngleUnit);
constexpr Gain kDecidegPerSecondPerRateUnit = gainOf(10.0f * kDegPerRad * kRadPerRateUnit);
FLY_INLINE int16_t scaled16(int32_t units, const Gain& gain) {  // inlined: the gain's shifts fold
  const int32_t v = applyGain(units, gain);
  return v > 32767 ? 32767 : (v < -32768 ? -32768 : static_cast<int16_t>(v));
}
}  // namespace

// ---------------------------------------------------------------------------------------------
// Start-up

void FlyApp::printBanner() { view::banner(); }

uint8_t FlyApp::loadCalibration() { return fw::loadAndReport(motors_); }

void FlyApp::start() {
  start_ms_ = hal::Clock::millis();
  starting_ = true;
  active_ = this;
  hal::Uart::setWaitHook(&FlyApp::serviceHook);
  motors_.setFrameRate(kLoopHz);  // the v2 bus filter's constant for one reading per frame
  configureMixer(mixer_.settings());
  output_.setMode(OutputMode::kForce, 0);
  gyro_cal_.restart();
  imu_.begin();
  schedule();
}

bool FlyApp::imuSettled() const { return imu_.running() || imu_.state() == ImuState::kFaulted; }

bool FlyApp::startImu() {
  runUntil(&FlyApp::imuSettled, kImuStartMaxMs);
  view::imuStarted(imu_);
  return imu_.running();
}

bool FlyApp::calibrateGyro() {
  if (imu_.running()) {
    view::calibrating();
    runUntil(&FlyApp::imuReady, kCalibrationMaxMs);
    if (imu_.fault() != ImuFault::kNone) {
      view::imuFault(imu_);
    } else {
      view::calibrationResult(*this);
    }
  }
  starting_ = false;
  prompt();
  return gyro_cal_.done();
}

void FlyApp::runUntil(bool (FlyApp::*done)() const, uint16_t max_ms) {
  const uint32_t from_ms = hal::Clock::millis();
  for (;;) {
    runOnce();
    if ((this->*done)() || hal::Clock::millis() - from_ms >= max_ms) return;
    hal::Clock::sleepUntil(&FlyApp::hasWork);
  }
}

void FlyApp::configureMixer(const MixerSettings& s) {
  mixer_.configure(s);
  controller_.setForceScale(mixer_.dgPerNmXy(), mixer_.dgPerNmZ());
}

// The read starts as late in the frame as the mode's computation allows.
void FlyApp::schedule() {
  const uint8_t mask = mixer_.motorMask();
  stats_.budget_us = computeBudgetUs(output_.mode(), output_.thesisMotors(mask), mixer_.motorCount());
  stats_.phase_us = readPhaseUs(stats_.budget_us);
  restartLoopStats();
  hal::Esc::setPhaseHook(stats_.phase_us, &FlyApp::phaseHook);
}

// The flight's worst computation and margin count from here (each arm, a new schedule).
void FlyApp::restartLoopStats() {
  stats_.compute_max_us = 0;
  stats_.margin_min_us = 0xFFFF;
  stats_.late = 0;
}

bool FlyApp::escsReady() const { return hal::Clock::millis() - start_ms_ >= tc::kArmMs; }

bool FlyApp::imuReady() const {
  return imu_.running() && imu_.fault() == ImuFault::kNone && gyro_cal_.done() && estimator_.started() &&
         imu_.badReads() == 0 && imu_.staleReads() == 0;
}

ArmInputs FlyApp::armInputs() const {
  ArmInputs in;
  in.armed = flight_.armed;
  in.escs_ready = escsReady();
  in.imu_fault = imu_.fault() != ImuFault::kNone;
  in.imu_ready = imuReady();
  const Attitude a = estimator_.attitude();
  in.roll_deg = a.roll_rad * kDegPerRad;
  in.pitch_deg = a.pitch_rad * kDegPerRad;
  for (uint8_t i = 0; i < 3; ++i) in.rate_dps[i] = a.rate_rad_s[i] * kDegPerRad;
  in.motors_ok = output_.motorsReady(mixer_.motorMask());
  in.mode_ready = output_.settingsReady();
  return in;
}

// ---------------------------------------------------------------------------------------------
// Main loop

void FlyApp::runOnce() {
  service();
  handleInput();
  printNotes();
}

bool FlyApp::hasWork() {
  if (active_ == nullptr) return false;
  return active_->imu_.frameDue() || (hal::Uart::available() && active_->consoleMayRun());
}

// Armed, or able to arm (the estimate runs): a line may start a flight, so its handling keeps
// out of the read like every armed line (the `arm` line handled across a read's end made the
// first flown frame late). Until then the loop sleeps to the next tick, not spins.
bool FlyApp::consoleMayRun() const {
  return !estimator_.started() || consoleMayStart(hal::Esc::frameTimeUs(), stats_.phase_us);
}

void FlyApp::phaseHook() {
  if (active_ != nullptr) active_->imu_.onPhase();
}

void FlyApp::serviceHook() {
  if (active_ != nullptr) active_->service();
}

void FlyApp::service() {
  if (in_service_) return;
  in_service_ = true;
  ImuFrame f;
  if (imu_.frameDue() && imu_.poll(f)) {
    // The computation counts from the read's end (taken by the TWI's interrupt), however late
    // the loop saw it: what thrustcal bench fly measures from outside.
    frame(f, f.has_sample ? hal::Twi::endFrameTimeUs() : hal::Esc::frameTimeUs());
    hal::Watchdog::kick();  // a frame came round: the only kick while flying
  }
  pollReceiver(hal::Clock::millis());  // after the pulses: its setpoint is the next frame's
  in_service_ = false;
}

void FlyApp::handleInput() {
  if (!consoleMayRun()) return;
  const fw::LineEvent event = line_.poll(kRxBytesPerPass);
  if (event == fw::LineEvent::kRejected) {  // its error line is printed; no keep-alive
    prompt();
    return;
  }
  if (event != fw::LineEvent::kLine) return;
  if (!line_.strict() || line_.checked()) link_.heard(hal::Clock::millis());
  char line[fw::kLineMax + 1];
  const char* src = line_.line();
  uint8_t n = 0;
  while (n < fw::kLineMax && src[n] != '\0') {
    line[n] = src[n];
    ++n;
  }
  line[n] = '\0';
  handleLine(line);  // commands.cpp
}

// What service() had to say; a prompt after it unless stream rows follow. During start-up
// startImu() and calibrateGyro() say it themselves.
void FlyApp::printNotes() {
  uint8_t notes = notes_;
  notes_ = 0;
  if ((notes & kNoteArmed) && flight_.armed && !flown_since_arm_) {  // not yet: see cmdArm
    notes_ = kNoteArmed;
    notes = static_cast<uint8_t>(notes & ~kNoteArmed);
  }
  if (notes == 0 || starting_) return;
  if (notes & kNoteArmed) view::armed(*this);
  if (notes & kNoteImuFault) view::imuFault(imu_);
  if (notes & kNoteImuRunning) view::imuRunningAgain();
  if (notes & kNoteLevel) view::levelResult(*this);
  if (notes & kNoteCalibrated) view::calibrationResult(*this);
  if (notes & kNoteStickArm) view::stickArm(*this);
  if (notes & kNoteDisarmed) view::disarmed(*this);
  if ((notes & kNoteStream) && streaming_) view::streamRow(row_);
  if ((notes & ~kNoteStream) != 0 && !streaming_) prompt();
}

void FlyApp::prompt() { fw::say(TC_FLASH_TEXT("fly> ")); }

// ---------------------------------------------------------------------------------------------
// The frame

void FlyApp::frame(const ImuFrame& f, uint16_t t0_us) {
  frame_ += f.frames;
  const uint16_t since = static_cast<uint16_t>(frames_since_sample_ + f.frames);
  frames_since_sample_ = since > 255 ? 255 : static_cast<uint8_t>(since);
  if (f.fault_now) imuFaulted();
  // Back after a fault: said at its first fresh sample (a frozen IMU restarts and takes its
  // settings every second, and is no better for it).
  if (f.has_sample && said_fault_ != ImuFault::kNone) {
    notes_ |= kNoteImuRunning;
    said_fault_ = ImuFault::kNone;
  }
  if (f.has_sample) {
    const uint8_t frames = frames_since_sample_;
    frames_since_sample_ = 0;
    if (estimator_.started()) {
      estimator_.propagate(f.sample, frames);
      if (flight_.armed) flyFrame(frames, t0_us);
    } else if (!flight_.armed && imu_.running() && gyro_cal_.add(f.sample)) {
      if (level_pending_) {
        level_pending_ = false;
        level_trimmed_ = estimator_.trimLevel(gyro_cal_);
        notes_ |= kNoteLevel;
      }
      estimator_.start(gyro_cal_);
      notes_ |= kNoteCalibrated;
    }
  }
  slowJob(f);
  checkFailsafes(hal::Clock::millis());
}

// The fast path, from the estimate to the written pulses (integer only, the spool-up too); then
// the integrators and the timing.
void FlyApp::flyFrame(uint8_t frames, uint16_t t0_us) {
  const uint32_t since_arm_ms = hal::Clock::millis() - flight_.armed_ms;
  const bool spooled = since_arm_ms >= kSpoolMs;
  const TorqueDg torque = controller_.torqueDg(estimator_.fixed(), command_.setpoint_q);
  const ForceLimits& l = flight_.limits;
  const ForceDg collective = spooled ? l.collective : spooledForce(l.collective, since_arm_ms);
  flight_.mix_limits = mixer_.mixDg(collective, torque, l.min, l.max, flight_.force);
  output_.compute(flight_.force, mixer_.motorMask());
  // The computation ends where the write begins (thrustcal bench fly measures the same span).
  const uint16_t t1_us = hal::Esc::frameTimeUs();
  output_.commit();
  flown_since_arm_ = true;

  // The read started at the phase: pulses written before the frame's end (at or after the
  // phase) meet the next rising edge; written after it (before the phase), the one after.
  const uint16_t compute_us =
      static_cast<uint16_t>(t1_us >= t0_us ? t1_us - t0_us : t1_us + kFrameUs - t0_us);
  if (compute_us > stats_.compute_max_us) stats_.compute_max_us = compute_us;
  if (t1_us < stats_.phase_us) {
    if (stats_.late != 0xFFFF) ++stats_.late;
  } else if (kFrameUs - t1_us < stats_.margin_min_us) {
    stats_.margin_min_us = static_cast<uint16_t>(kFrameUs - t1_us);
  }
  if (spooled && controller_.integrating(command_.setpoint.mode))
    controller_.integrate(estimator_.attitude(), command_.setpoint, frames * kFramePeriodS, flight_.mix_limits);
}

// After the pulses: each slow job on its own frame of a cycle of eight (fly_rules.hpp).
void FlyApp::slowJob(const ImuFrame& f) {
  switch (fly::slowJob(frame_)) {
    case SlowJob::kBattery:
      motors_.sampleBattery();
      break;
    case SlowJob::kBatteryModel:
      if (output_.mode() == OutputMode::kArduPilot) {
        output_.batteryRead(kSlowCycleS);
        if (flight_.armed) updateOutputLimits();  // lift_max follows the voltage
      }
      break;
    case SlowJob::kRollCorrection:
      if (f.has_sample && estimator_.started()) estimator_.correctRoll(f.sample, kSlowCycleS);
      break;
    case SlowJob::kPitchCorrection:
      if (f.has_sample && estimator_.started()) estimator_.correctPitch(f.sample, kSlowCycleS);
      break;
    case SlowJob::kStreamRow:
      if (streaming_) takeStreamRow(hal::Clock::millis());
      break;
    case SlowJob::kNone:
      break;
  }
}

void FlyApp::checkFailsafes(uint32_t now_ms) {
  if (!flight_.armed) return;
  const AttitudeQ& q = estimator_.fixed();
  if (crashedUnits(q.roll, q.pitch, command_.crash_units)) {
    const Attitude a = estimator_.attitude();
    const float roll = a.roll_rad < 0 ? -a.roll_rad : a.roll_rad;
    const float pitch = a.pitch_rad < 0 ? -a.pitch_rad : a.pitch_rad;
    flight_.cause_deg = (roll > pitch ? a.roll_rad : a.pitch_rad) * kDegPerRad;
    disarm(DisarmCause::kCrash);
  } else if (flight_.source == ArmSource::kConsole && link_.lost(now_ms)) {
    ++link_.trips;
    disarm(DisarmCause::kLink);
  } else if (flight_.source == ArmSource::kSticks && receiverLost(now_ms, receiver_.last_frame_ms)) {
    if (receiver_.trips != 0xFFFF) ++receiver_.trips;
    disarm(DisarmCause::kRcLost);
  }
}

// The IMU faulted (mpu6050.hpp): disarm, and measure the gyro again once it runs. Said once per
// kind of fault: a start-up that fails every second alike stays quiet.
void FlyApp::imuFaulted() {
  if (flight_.armed) disarm(DisarmCause::kImu);
  gyro_cal_.restart();
  estimator_.stop();
  if (imu_.fault() != said_fault_) notes_ |= kNoteImuFault;
  said_fault_ = imu_.fault();
}

// The mode's range and collective; while the sticks fly, the throttle's share of the range.
void FlyApp::updateOutputLimits() {
  flight_.limits = output_.forceLimits(settings_.thrust_g, mixer_.motorMask(), mixer_.motorCount());
  if (flight_.armed && flight_.source == ArmSource::kSticks)
    flight_.limits.collective =
        (flight_.limits.max * StickCommand::throttleShareQ10(receiver_.sticks.throttle_us) + 512) >> 10;
}

void FlyApp::disarm(DisarmCause cause) {
  output_.stop();  // every ESC to the stop pulse, now
  flight_.armed = false;
  flight_.last_cause = cause;
  if (flight_.disarms != 0xFFFF) ++flight_.disarms;
  flight_.force = Forces();
  notes_ |= kNoteDisarmed;
}

void FlyApp::takeStreamRow(uint32_t now_ms) {
  const AttitudeQ& q = estimator_.fixed();
  // Seconds and milliseconds by advancing the last row's (20 ms a row: a subtraction at most),
  // not by a 32-bit division each row; a row a minute or more after the last divides once.
  const uint32_t since_ms = now_ms - row_.from_ms;
  if (since_ms >= 60000u) {
    row_.t_s = now_ms / 1000u;
    row_.t_ms = static_cast<uint16_t>(now_ms - row_.t_s * 1000u);
  } else {
    uint16_t ms = static_cast<uint16_t>(row_.t_ms + since_ms);
    while (ms >= 1000u) {
      ms = static_cast<uint16_t>(ms - 1000u);
      ++row_.t_s;
    }
    row_.t_ms = ms;
  }
  row_.from_ms = now_ms;
  row_.roll_cdeg = scaled16(q.roll, kCentidegPerAngleUnit);
  row_.pitch_cdeg = scaled16(q.pitch, kCentidegPerAngleUnit);
  row_.roll_sp_cdeg = scaled16(command_.setpoint_q.roll, kCentidegPerAngleUnit);
  row_.pitch_sp_cdeg = scaled16(command_.setpoint_q.pitch, kCentidegPerAngleUnit);
  for (uint8_t i = 0; i < 3; ++i) row_.rate_ddps[i] = scaled16(q.rate[i], kDecidegPerSecondPerRateUnit);
  for (uint8_t i = 0; i < kMotors; ++i) {
    const ForceDg dg = flight_.force.dg[i];
    row_.force_dg[i] = dg <= 0 ? 0 : (dg > 32767 ? 32767 : static_cast<int16_t>(dg));
    row_.pulse_us[i] = output_.pulseUs(i);
  }
  notes_ |= kNoteStream;
}

}  // namespace fly

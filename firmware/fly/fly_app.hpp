// fly: attitude control on the calibrated actuators (issue 19). A user's flight code as the
// thesis's Iqarus had it, on the public force API (firmware/common/force_actuators.hpp) so it is
// the example users copy: an MPU-6050 on the TWI, a 400 Hz loop timed by the ESC frames, a PID on
// roll and pitch and a PI on the yaw rate in N m, a plus/X mixer into four forces in grams, and
// those forces to pulses by one of four modes, to compare on one airframe (docs/fly.md).
//
// Flow (main.cpp): hardware init -> banner -> loadCalibration() (the four slots, once) -> start()
// -> startImu() (WHO_AM_I, its settings) -> calibrateGyro() (the bias at rest) -> runOnce()
// forever. Everything after start() happens in frames: every ESC frame the phase hook (an
// interrupt, readPhaseUs() after the rising edge) starts the IMU read; when it has ended the
// main loop's service() runs frame(): the estimator, and while armed the controller, the mixer
// and the output stage, whose pulses the next rising edge carries; then one slow job (battery,
// an accelerometer correction, a stream row), the failsafes, and the watchdog's kick.
//
// Safety rules (docs/safety.md, "The rules"), all enforced here:
//  - nothing spins unless a complete, valid `arm` line asked (with strict on: checksummed), the
//    ESCs had their 2 s at the stop pulse, the IMU is healthy and its gyro calibrated, the
//    vehicle is level and still, and every motor the layout flies can fly in the mode;
//  - disarmed (every ESC to the stop pulse at once, nothing spins until a new `arm`) on: roll or
//    pitch beyond the crash limit; an IMU fault (no answer, wrong WHO_AM_I, a stuck bus, frozen
//    data: mpu6050.hpp); no complete line for tc::kFailsafeMs (the link); `disarm`. Each within
//    a few frames of its cause;
//  - the watchdog is kicked once per frame handled, from service() only: a hang anywhere (the
//    loop, an interrupt that never returns, a frame hook that stops) resets the chip within
//    ~64 ms, and after any reset nothing spins until commanded;
//  - a pass of the main loop handles at most one line; a reply that fills the transmit ring
//    runs service() from the UART's wait hook, so frames stay on time.
//
// Parts, one job each: the loop's stages side by side, each on the flight types of
// flight_types.hpp and on no other stage: Mpu6050 (the IMU), GyroCalibration and
// AttitudeEstimator (estimator.hpp), AttitudeController, Mixer, OutputStage (with
// ArduPilotCurve, on fw::ForceActuators); the console's fw::LineReader and fw::LinkWatch;
// fly_rules.hpp holds the pure decisions. Each stage's tunables are a plain settings struct
// (ControllerSettings, MixerSettings, OutputSettings, LevelTrim, FlightSettings). Files:
// fly_app.cpp (start-up, the loop, frames, arming), commands.cpp (the command table and the
// cmd methods), fly_view.cpp and fly_status_view.cpp (every line printed), params*.cpp (the
// saved parameters: their table, the `param` commands, the EEPROM record).
#pragma once
#include <stdint.h>

#include "console.hpp"
#include "controller.hpp"
#include "estimator.hpp"
#include "flight_types.hpp"
#include "fly_rules.hpp"
#include "force_actuators.hpp"
#include "shell.hpp"
#include "mixer.hpp"
#include "mpu6050.hpp"
#include "output_stage.hpp"
#include "rc_input.hpp"

namespace fly {

// Received bytes one loop pass handles at most: one longest line and its CR LF.
constexpr uint8_t kRxBytesPerPass = fw::kLineMax + 2;

// The flight's own settings (commands.cpp; fly's parameters point at them). The stages keep
// theirs: ControllerSettings, MixerSettings, OutputSettings, LevelTrim.
struct FlightSettings {
  float thrust_g = 0;  // collective: the total over the layout's motors
  uint8_t crash_deg = kDefaultCrashDeg;
};

// What the flight flies now: the setpoint (console or receiver), in both units.
struct FlightCommand {
  Setpoint setpoint;
  SetpointQ setpoint_q;  // the same in the frame path's units
  int32_t crash_units = angleUnitsOfDegrees(kDefaultCrashDeg);  // the crash limit in angle units
};

// The flight's state: armed or not, why it last disarmed, the last frame's output.
struct FlightState {
  bool armed = false;
  ArmSource source = ArmSource::kConsole;
  uint32_t armed_ms = 0;
  DisarmCause last_cause = DisarmCause::kNone;
  float cause_deg = 0;  // kCrash: the angle that crossed the limit
  uint16_t disarms = 0;
  uint8_t mix_limits = 0;
  Forces force;
  // The output's limits, worked out at arming, on a new thrust and at each battery reading.
  ForceLimits limits;
};

// The receiver as the app sees it (fly_receiver.cpp).
struct ReceiverState {
  Sticks sticks;                 // the last valid frame's
  bool seen = false;             // a valid frame came since `rc` was set
  uint32_t last_frame_ms = 0;    // when the last valid frame came
  uint32_t last_edge_ms = 0;     // when edges were last drained (a gap resets the decoder)
  StickGesture gesture = StickGesture::kNone;  // held since gesture_ms
  uint32_t gesture_ms = 0;
  bool gesture_used = false;     // the held gesture did what it does; release to repeat
  ArmRefusal refused = ArmRefusal::kNone;  // the sticks' last arming attempt
  uint16_t trips = 0;            // receiver failsafes (saturates)
  uint16_t lost_edges = 0;       // hal::Rc::lostEdges() as last seen
};

// The loop's timing, as frameTimeUs() sees it (status; thrustcal bench measures the same spans in
// simavr). The figures count from the last arm (or mode change), spool-up included.
struct LoopStats {
  uint16_t phase_us = 0;            // where in the frame the read starts
  uint16_t budget_us = 0;           // the computation it leaves room for
  uint16_t compute_max_us = 0;      // from the read's end to the pulses' write
  uint16_t margin_min_us = 0xFFFF;  // from the written pulses to the next rising edge
  uint16_t late = 0;                // pulses written after the frame they were meant for had ended
};

// One stream row, taken in its frame and printed after it.
struct StreamRow {
  uint32_t t_s = 0;    // the time since start-up: seconds
  uint16_t t_ms = 0;   // ... and milliseconds, 0..999
  uint32_t from_ms = 0;  // the clock at the last row (the time advances by the difference)
  int16_t roll_cdeg = 0, pitch_cdeg = 0, roll_sp_cdeg = 0, pitch_sp_cdeg = 0;
  int16_t rate_ddps[3] = {0, 0, 0};
  int16_t force_dg[kMotors] = {0, 0, 0, 0};  // decigrams, as the mixer gives them
  uint16_t pulse_us[kMotors] = {0, 0, 0, 0};
};

class FlyApp {
 public:
  FlyApp() : output_(motors_) {}

  // Prints the program name, why the chip reset and how to get help.
  void printBanner();
  // The board settings and the four slots, once; reports each. Returns the calibrated count.
  uint8_t loadCalibration();
  // The frames begin: the phase hook, the UART wait hook, the IMU's start-up.
  void start();
  // Run the loop until the IMU has answered and taken its settings, or faulted (at most 1 s);
  // says which. True: it runs.
  bool startImu();
  // Run the loop until the gyro's bias is measured at rest (at most 5 s); says so, or that it
  // goes on in the background. True: calibrated.
  bool calibrateGyro();
  // One pass of the main loop: service(), at most one line, then the notes service() left.
  // Does not sleep: the caller sleeps afterwards, until hasWork() (hal::Clock::sleepUntil).
  void runOnce();
  // A pass has something to do: a frame to handle, a received byte. Called with interrupts off.
  static bool hasWork();

  // Observers (status, tests).
  bool armed() const { return flight_.armed; }
  const FlightState& flight() const { return flight_; }
  const FlightSettings& settings() const { return settings_; }
  const FlightCommand& command() const { return command_; }
  Attitude attitude() const { return estimator_.attitude(); }
  const AttitudeEstimator& estimator() const { return estimator_; }
  const AttitudeController& controller() const { return controller_; }
  const Mixer& mixer() const { return mixer_; }
  const OutputStage& output() const { return output_; }
  const Mpu6050& imu() const { return imu_; }
  const GyroCalibration& gyroCalibration() const { return gyro_cal_; }
  bool levelTrimmed() const { return level_trimmed_; }  // the last `level` took its trim
  const fw::ForceActuators& motors() const { return motors_; }
  const LoopStats& loopStats() const { return stats_; }
  const fw::LineReader& console() const { return line_; }
  const LinkWatch& link() const { return link_; }
  const RcDecoder& rc() const { return rc_; }
  const RcSettings& rcSettings() const { return rc_settings_; }
  const StickCommand& stickCommand() const { return stick_command_; }
  const ReceiverState& receiver() const { return receiver_; }
  uint32_t frames() const { return frame_; }
  bool imuReady() const;
  bool escsReady() const;
  bool isStreaming() const { return streaming_; }
  ArmInputs armInputs() const;

  // `help`: every row of the command table, then the rules; docs/fly.md holds a copy a test
  // compares with it.
  static void printHelp();

 private:
  friend struct Commands;  // commands.cpp: the table's handlers, one call each to a cmd method
  friend struct Params;    // params.cpp: the saved parameters read and write the settings

  // Commands (commands.cpp), arguments parsed and range-checked by the table.
  void cmdArm();
  void cmdDisarm();
  void cmdSetpoint(int8_t roll_deg, int8_t pitch_deg);
  void cmdThrust(uint16_t thrust_g);
  void cmdGains(uint16_t kp, uint16_t ki, uint16_t kd);
  void cmdYawGains(uint16_t kp, uint16_t ki);
  void cmdMode(OutputMode mode, uint8_t generic_slot);
  void cmdLayout(Layout layout);
  void cmdAirframe(uint16_t arm_mm, uint16_t yaw_arm_um);
  void cmdHover(uint16_t hover_us, uint16_t slope_mg_per_us);
  void cmdArduPilot(int16_t expo_e4, uint16_t spin_min_e4, uint16_t spin_max_e4, uint16_t full_g);
  void cmdArduPilotVolts(uint16_t max_mv, uint16_t min_mv);
  void cmdArduPilotPwm(uint16_t min_us, uint16_t max_us);
  void cmdCrash(uint8_t deg);
  void cmdCalibrate();
  void cmdLevel();
  void cmdStream(bool on);
  void cmdStatus();
  void cmdStrict(bool on);
  void cmdDyn(const fw::ArgValues& args);
  void cmdRc(RcProtocol protocol, uint8_t pwm_channels);
  void cmdRcMap(uint8_t which);
  void cmdRates(uint8_t angle_deg, uint16_t rate_dps, uint16_t yaw_dps);
  void cmdFlightMode(FlightMode mode);
  bool refuseWhileArmed() const;  // prints the refusal when armed
  bool refuseWhileSticksFly() const;
  // Arms from `source` when every check passes (armRefusal); the refusal otherwise.
  ArmRefusal arm(ArmSource source);

  void handleLine(char* line);
  void handleInput();
  bool consoleMayRun() const;  // a console line may be handled now (fly_rules.hpp)
  void printNotes();
  void prompt();
  void runUntil(bool (FlyApp::*done)() const, uint16_t max_ms);
  bool imuSettled() const;

  // The time-critical part of a pass, also run from inside a blocked write (the UART wait
  // hook): the frame, when its IMU read has ended, and the watchdog's kick. Prints nothing.
  void service();
  static void serviceHook();
  static void phaseHook();
  void frame(const ImuFrame& f, uint16_t t0_us);
  void flyFrame(uint8_t frames, uint16_t t0_us);
  void slowJob(const ImuFrame& f);
  void checkFailsafes(uint32_t now_ms);
  // The receiver (fly_receiver.cpp): its edges drained, frames to sticks, gestures, setpoint.
  void pollReceiver(uint32_t now_ms);
  void onReceiverFrame(uint32_t now_ms);
  void stickGestures(uint32_t now_ms);
  void flyTheSticks();
  // The receiver's settings (rc_settings_) to the decoder and the pins (`rc`, saved settings).
  void applyReceiverSettings();
  void imuFaulted();
  void takeStreamRow(uint32_t now_ms);
  void disarm(DisarmCause cause);
  void schedule();  // the read's phase from the mode's budget
  void restartLoopStats();
  void configureMixer(const MixerSettings& s);  // the airframe to the mixer, its scale to the controller
  void updateOutputLimits();

  fw::ForceActuators motors_;
  Mpu6050 imu_;
  GyroCalibration gyro_cal_;
  AttitudeEstimator estimator_;
  AttitudeController controller_;
  Mixer mixer_;
  OutputStage output_;
  fw::LineReader line_;
  LinkWatch link_;
  RcDecoder rc_;
  RcSettings rc_settings_;
  StickCommand stick_command_;
  ReceiverState receiver_;
  FlightSettings settings_;
  FlightCommand command_;
  FlightState flight_;
  LoopStats stats_;
  StreamRow row_;
  uint32_t frame_ = 0;  // frames since start()
  uint32_t start_ms_ = 0;
  uint8_t frames_since_sample_ = 0;
  ImuFault said_fault_ = ImuFault::kNone;  // the fault last printed: a retry that fails alike is not news
  bool starting_ = false;                  // start() .. calibrateGyro(): they say what the notes would
  bool streaming_ = false;
  bool in_service_ = false;
  bool hold_prompt_ = false;
  bool level_pending_ = false;  // `level`: the calibration under way sets the level trim
  bool level_trimmed_ = false;

  // service() -> printNotes(): what happened.
  static constexpr uint8_t kNoteDisarmed = 0x01;
  static constexpr uint8_t kNoteImuFault = 0x02;
  static constexpr uint8_t kNoteCalibrated = 0x04;
  static constexpr uint8_t kNoteStream = 0x08;
  static constexpr uint8_t kNoteImuRunning = 0x10;
  static constexpr uint8_t kNoteLevel = 0x20;
  static constexpr uint8_t kNoteStickArm = 0x40;  // the sticks armed, or were refused (receiver_.refused)
  static constexpr uint8_t kNoteArmed = 0x80;     // `arm` armed: said after the first flown frame
  uint8_t notes_ = 0;
  bool flown_since_arm_ = false;  // a frame computed its pulses since the last arm
  static FlyApp* active_;  // the instance the hooks serve
};

}  // namespace fly

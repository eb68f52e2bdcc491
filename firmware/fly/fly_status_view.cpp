// fly's `status` and stream rows (fly_view.hpp): what the image says of its state, nothing it
// decides.
#include "fly_view.hpp"

#include "fly_view_parts.hpp"
#include "params.hpp"
#include "dyn_console.hpp"
#include "slot_report.hpp"

namespace fly {
namespace view {

using fw::newline;
using fw::say;
using fw::sayLine;

namespace {

void statusState(const FlyApp& app) {
  say(app.flight().armed ? TC_FLASH_TEXT("state: armed") : TC_FLASH_TEXT("state: disarmed"));
  say(TC_FLASH_TEXT(", disarms "));
  sayCount(app.flight().disarms);
  say(TC_FLASH_TEXT(", mode "));
  say(modeName(app.output().mode()));
  say(TC_FLASH_TEXT(", layout "));
  say(layoutName(app.mixer().layout()));
  newline();
}

void statusImu(const FlyApp& app) {
  const Mpu6050& imu = app.imu();
  say(TC_FLASH_TEXT("imu: "));
  if (imu.fault() != ImuFault::kNone) {
    say(TC_FLASH_TEXT("fault: "));
    sayFault(imu);
  } else {
    say(imu.running() ? TC_FLASH_TEXT("running") : TC_FLASH_TEXT("starting"));
  }
  say(TC_FLASH_TEXT("; reads "));
  sayCount(imu.readsOk());
  say(TC_FLASH_TEXT(", bad in a row "));
  sayCount(imu.badReads());
  say(TC_FLASH_TEXT(", stale "));
  sayCount(imu.staleReads());
  say(TC_FLASH_TEXT(", faults "));
  sayCount(imu.faults());
  say(TC_FLASH_TEXT(", bus recoveries "));
  sayCount(imu.recoveries());
  say(app.gyroCalibration().done() ? TC_FLASH_TEXT(", gyro calibrated")
                                   : TC_FLASH_TEXT(", gyro not calibrated"));
  newline();
}

void statusAttitude(const FlyApp& app) {
  const Attitude a = app.attitude();
  say(TC_FLASH_TEXT("attitude: roll "));
  sayDeg(a.roll_rad);
  say(TC_FLASH_TEXT(" pitch "));
  sayDeg(a.pitch_rad);
  say(TC_FLASH_TEXT(" deg, rates"));
  for (uint8_t i = 0; i < 3; ++i) {
    hal::Uart::write(' ');
    sayDeg(a.rate_rad_s[i]);
  }
  sayLine(TC_FLASH_TEXT(" deg/s"));
}

void statusLoop(const FlyApp& app, const LoopStats& s) {
  say(TC_FLASH_TEXT("loop: "));
  sayFrameLayout(app);
  say(TC_FLASH_TEXT("; armed: computation at most "));
  sayCount(s.compute_max_us);
  say(TC_FLASH_TEXT(" us, pulses written at least "));
  sayCount(s.margin_min_us == 0xFFFF ? 0 : s.margin_min_us);
  say(TC_FLASH_TEXT(" us before the edge, late "));
  sayCount(s.late);
  say(TC_FLASH_TEXT(", frames skipped "));
  sayCount(app.imu().skippedFrames());
  newline();
}

// What the integrators hold now (the mismatch they absorb; 0 without integral gains).
void statusIntegrators(const FlyApp& app) {
  say(TC_FLASH_TEXT("integrators: roll "));
  sayFloat(app.controller().integralNm(0) * 1000.0f, 1);
  say(TC_FLASH_TEXT(" pitch "));
  sayFloat(app.controller().integralNm(1) * 1000.0f, 1);
  say(TC_FLASH_TEXT(" yaw "));
  sayFloat(app.controller().integralNm(2) * 1000.0f, 1);
  sayLine(TC_FLASH_TEXT(" mN m"));
}

// "motor N: F g, P us; slot S (model v2)" and what keeps it from flying.
void statusMotor(const FlyApp& app, uint8_t i) {
  const fw::Motor& m = app.motors().motor(i);
  fw::sayMotor(i);
  say(TC_FLASH_TEXT(": "));
  sayFixed(roundedGrams(app.flight().force.dg[i]), 0);
  say(TC_FLASH_TEXT(" g, "));
  sayCount(app.output().pulseUs(i));
  say(TC_FLASH_TEXT(" us; slot "));
  sayCount(m.source);
  say(TC_FLASH_TEXT(" "));
  if (app.motors().isArmable(i)) {
    say(app.motors().motor(m.source).fliesV2() ? TC_FLASH_TEXT("(model v2)")
                                               : TC_FLASH_TEXT("(thesis record)"));
  } else {
    fw::sayRecordStatus(app.motors().motor(m.source));
  }
  if (!app.mixer().flies(i)) say(TC_FLASH_TEXT(", not in this layout"));
  newline();
}

// "receiver: ppm, 812 frames, last 12 ms ago, rejected pulses 3, bad frames 1, ...; sticks ..."
void statusReceiver(const FlyApp& app) {
  if (app.rcSettings().protocol == RcProtocol::kOff) {
    sayLine(TC_FLASH_TEXT("receiver: off (rc ppm|pwm to read one)"));
    return;
  }
  const RcDecoder& d = app.rc();
  const ReceiverState& r = app.receiver();
  say(TC_FLASH_TEXT("receiver: frames "));
  sayCount(d.frames());
  if (r.seen) {
    say(TC_FLASH_TEXT(", last "));
    sayMs(hal::Clock::millis() - r.last_frame_ms);
    say(TC_FLASH_TEXT(" ago"));
  }
  say(TC_FLASH_TEXT(", rejected pulses "));
  sayCount(d.rejectedPulses());
  say(TC_FLASH_TEXT(", bad frames "));
  sayCount(d.badFrames());
  say(TC_FLASH_TEXT(", lost edges "));
  sayCount(r.lost_edges);
  say(TC_FLASH_TEXT(", failsafes "));
  sayCount(r.trips);
  say(TC_FLASH_TEXT("; sticks roll "));
  sayFixed(r.sticks.roll, 0);
  say(TC_FLASH_TEXT(" pitch "));
  sayFixed(r.sticks.pitch, 0);
  say(TC_FLASH_TEXT(" yaw "));
  sayFixed(r.sticks.yaw, 0);
  say(TC_FLASH_TEXT(" us, throttle "));
  sayCount(r.sticks.throttle_us);
  say(r.sticks.mode == FlightMode::kRate ? TC_FLASH_TEXT(" us, rate mode") : TC_FLASH_TEXT(" us, angle mode"));
  newline();
}

}  // namespace

// `yield` (not null) between the lines: the frames run there.
void status(const FlyApp& app, const LoopStats& loop, void (*yield)()) {
  statusState(app);
  yield();
  statusImu(app);
  yield();
  statusAttitude(app);
  yield();
  setpoint(app);
  thrust(app);
  yield();
  gains(app);
  crashLimit(app);
  yield();
  Params::sayStatus(app);
  yield();
  statusIntegrators(app);
  yield();
  statusLoop(app, loop);
  for (uint8_t i = 0; i < kMotors; ++i) {
    yield();
    statusMotor(app, i);
  }
  yield();
  fw::dynState(app.motors());
  yield();
  statusReceiver(app);
  yield();
  say(TC_FLASH_TEXT("battery "));
  fw::sayVolts(app.motors().batteryMv());
  say(TC_FLASH_TEXT(" raw; link failsafe trips "));
  sayCount(app.link().trips);
  newline();
  fw::printHealth(app.console(), yield);  // frames go on during the stack scan
}

void streamHeader() {
  sayLine(
      TC_FLASH_TEXT("t_s,roll_deg,pitch_deg,roll_sp_deg,pitch_sp_deg,p_dps,q_dps,r_dps,"
                    "force0_g,force1_g,force2_g,force3_g,pulse0_us,pulse1_us,pulse2_us,pulse3_us"));
}

// Every number 16 bits (formatFixed16: no 32-bit division); the time as seconds and
// milliseconds. The row is built in one buffer and handed to the UART at once (hal::Uart::print
// fills its ring in runs): one call per row, not one per character.
void streamRow(const StreamRow& row) {
  constexpr uint8_t kFields = 4 + 3 + 2 * kMotors;  // after the time
  char text[2 * (fw::kFixed16Chars + 1) + kFields * (fw::kFixed16Chars + 1) + 3];
  char* p = text;
  if (row.t_s <= 32767u) {
    p = fw::formatFixed16(p, static_cast<int16_t>(row.t_s), 0);
  } else {
    sayCount(row.t_s);  // after nine hours: printed on its own
  }
  *p++ = '.';
  if (row.t_ms < 100) *p++ = '0';
  if (row.t_ms < 10) *p++ = '0';
  p = fw::formatFixed16(p, static_cast<int16_t>(row.t_ms), 0);
  const int16_t cdeg[4] = {row.roll_cdeg, row.pitch_cdeg, row.roll_sp_cdeg, row.pitch_sp_cdeg};
  for (int16_t v : cdeg) {
    *p++ = ',';
    p = fw::formatFixed16(p, v, 2);
  }
  for (int16_t v : row.rate_ddps) {
    *p++ = ',';
    p = fw::formatFixed16(p, v, 1);
  }
  for (int16_t v : row.force_dg) {
    *p++ = ',';
    p = fw::formatFixed16(p, v, 1);  // grams with the decigram the mixer works in
  }
  for (uint16_t v : row.pulse_us) {
    *p++ = ',';
    p = fw::formatFixed16(p, static_cast<int16_t>(v), 0);
  }
  *p++ = '\r';
  *p++ = '\n';
  *p = '\0';
  hal::Uart::print(text);
}


}  // namespace view
}  // namespace fly

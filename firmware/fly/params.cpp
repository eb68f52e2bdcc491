// fly's parameters (params.hpp): capture and apply (the binding to fly's settings), the record
// at start-up, and the `param` commands. Every line they print is in params_view.cpp.
#include "params.hpp"

#include "fly_app.hpp"
#include "params_view.hpp"

namespace fly {

namespace {

tc::ParamTable table() {
  tc::ParamTable t;
  tc::flashCopy(&t, &kParamTable, sizeof t);
  return t;
}

// Out of line: two dozen inlined float conversions cost ~1.5 KB of flash on the AVR.
__attribute__((noinline)) int32_t rounded(float x, float scale) {
  const float v = x * scale;
  return static_cast<int32_t>(v < 0 ? v - 0.5f : v + 0.5f);
}
__attribute__((noinline)) float times(int32_t v, float scale) { return static_cast<float>(v) * scale; }

// The accelerometer's trim: 0.1 mg in the table, LSB in the estimator (the table's step is
// finer than the sensor's 0.244 mg, so LSB -> 0.1 mg -> LSB is exact).
constexpr float kDmgPerLsb = 10000.0f / kAccelLsbPerG;

// hal::Eeprom, with the frames served after every byte: on the chip a byte takes ~3.4 ms,
// and a save of ~50 bytes would otherwise hold the loop (and its watchdog kick) for 170 ms.
struct ServedEeprom {
  static uint8_t readByte(uint16_t addr) { return hal::Eeprom::readByte(addr); }
  static void updateByte(uint16_t addr, uint8_t value) {
    hal::Eeprom::updateByte(addr, value);
    Params::serve();
  }
};

// The receiver's map as the index of its word in kRcMapWords (0 when it is none of them).
uint8_t rcMapIndex(const char (&map)[5]) {
  char word[5];
  for (uint8_t i = 0; tc::flashWordCopy(kRcMapWords, i, word, sizeof word) != 0; ++i) {
    bool same = true;
    for (uint8_t c = 0; c < 4; ++c) same = same && word[c] == map[c];
    if (same) return i;
  }
  return 0;
}

}  // namespace

void Params::serve() { FlyApp::serviceHook(); }

// long: one line per parameter, each read from its stage's settings struct
void Params::capture(const FlyApp& app, ParamValues& v) {
  const ControllerSettings& c = app.controller_.settings();
  v[kParamAngleKp] = rounded(c.angle.kp_nm_per_rad, 1000);
  v[kParamAngleKi] = rounded(c.angle.ki_nm_per_rad_s, 1000);
  v[kParamAngleKd] = rounded(c.angle.kd_nm_s_per_rad, 1000);
  v[kParamRateKp] = rounded(c.rate.kp_nm_s_per_rad, 1000);
  v[kParamRateKi] = rounded(c.rate.ki_nm_per_rad, 1000);
  v[kParamYawKp] = rounded(c.yaw.kp_nm_s_per_rad, 1000);
  v[kParamYawKi] = rounded(c.yaw.ki_nm_per_rad, 1000);
  v[kParamCrashDeg] = app.settings_.crash_deg;
  const MixerSettings& m = app.mixer_.settings();
  v[kParamLayoutWord] = static_cast<int32_t>(m.layout);
  v[kParamArmMm] = rounded(m.arm_m, 1000);
  v[kParamYawArmUm] = rounded(m.yaw_arm_m, 1000000);
  const OutputSettings& o = app.output_.settings();
  v[kParamMode] = static_cast<int32_t>(o.mode);
  v[kParamGenericSlot] = o.generic_slot;
  v[kParamHoverUs] = o.pwm.hover_us;
  v[kParamHoverSlope] = rounded(o.pwm.slope_g_per_us, 1000);
  const ArduPilotParams& ap = app.output_.arduPilot().params();
  v[kParamApExpo] = rounded(ap.expo, 10000);
  v[kParamApSpinMin] = rounded(ap.spin_min, 10000);
  v[kParamApSpinMax] = rounded(ap.spin_max, 10000);
  v[kParamApFullG] = rounded(ap.full_thrust_g, 1);
  v[kParamApVoltMin] = rounded(ap.bat_volt_min_v, 1000);
  v[kParamApVoltMax] = rounded(ap.bat_volt_max_v, 1000);
  v[kParamApPwmMin] = ap.pwm_min_us;
  v[kParamApPwmMax] = ap.pwm_max_us;
  for (uint8_t i = 0; i < 3; ++i) v[kParamLevelX + i] = rounded(app.estimator_.levelTrim().lsb[i], kDmgPerLsb);
  const RcSettings& rc = app.rc_settings_;
  v[kParamRcProtocol] = static_cast<int32_t>(rc.protocol);
  v[kParamRcChannels] = rc.pwm_channels;
  v[kParamRcMap] = rcMapIndex(rc.map);
  v[kParamRcModeChannel] = rc.mode_channel < kRcMaxChannels ? rc.mode_channel + 1 : 0;
  v[kParamFlightMode] = static_cast<int32_t>(rc.default_mode);
  const StickSettings& st = app.stick_command_.settings();
  v[kParamStickAngleDeg] = st.max_angle_deg;
  v[kParamStickRateDps] = st.max_rate_dps;
  v[kParamStickYawDps] = st.max_yaw_rate_dps;
}

// long: one block per group, each the same calls as its setting command (commands.cpp, fly_receiver.cpp)
bool Params::apply(FlyApp& app, const ParamValues& v, uint16_t mask) {
  if (mask & (1u << kGroupGains)) {
    ControllerSettings c = app.controller_.settings();  // a copy, not a default: no template in SRAM
    c.angle = {times(v[kParamAngleKp], 0.001f), times(v[kParamAngleKi], 0.001f), times(v[kParamAngleKd], 0.001f)};
    c.rate = {times(v[kParamRateKp], 0.001f), times(v[kParamRateKi], 0.001f)};
    c.yaw = {times(v[kParamYawKp], 0.001f), times(v[kParamYawKi], 0.001f)};
    app.controller_.setSettings(c);
  }
  if (mask & (1u << kGroupCrash)) {
    app.settings_.crash_deg = static_cast<uint8_t>(v[kParamCrashDeg]);
    app.command_.crash_units = angleUnitsOfDegrees(app.settings_.crash_deg);
  }
  if (mask & (1u << kGroupMixer)) {
    MixerSettings m = app.mixer_.settings();
    m.layout = static_cast<Layout>(v[kParamLayoutWord]);
    m.arm_m = times(v[kParamArmMm], 0.001f);
    m.yaw_arm_m = times(v[kParamYawArmUm], 0.000001f);
    app.configureMixer(m);
  }
  bool mode_taken = true;
  if (mask & (1u << kGroupMode))
    mode_taken = app.output_.setMode(static_cast<OutputMode>(v[kParamMode]), static_cast<uint8_t>(v[kParamGenericSlot]));
  if (mask & (1u << kGroupPwm)) {
    PwmModeParams p = app.output_.pwmParams();
    p.hover_us = static_cast<uint16_t>(v[kParamHoverUs]);
    p.slope_g_per_us = times(v[kParamHoverSlope], 0.001f);
    app.output_.setPwmParams(p);
  }
  if (mask & (1u << kGroupArduPilot)) {
    ArduPilotParams p = app.output_.arduPilot().params();
    p.expo = times(v[kParamApExpo], 0.0001f);
    p.spin_min = times(v[kParamApSpinMin], 0.0001f);
    p.spin_max = times(v[kParamApSpinMax], 0.0001f);
    p.full_thrust_g = static_cast<float>(v[kParamApFullG]);
    p.bat_volt_min_v = times(v[kParamApVoltMin], 0.001f);
    p.bat_volt_max_v = times(v[kParamApVoltMax], 0.001f);
    p.pwm_min_us = static_cast<uint16_t>(v[kParamApPwmMin]);
    p.pwm_max_us = static_cast<uint16_t>(v[kParamApPwmMax]);
    app.output_.setArduPilotParams(p);
  }
  if (mask & (1u << kGroupLevel)) {
    LevelTrim trim = app.estimator_.levelTrim();
    for (uint8_t i = 0; i < 3; ++i)
      trim.lsb[i] = static_cast<int16_t>(rounded(static_cast<float>(v[kParamLevelX + i]), 1.0f / kDmgPerLsb));
    app.estimator_.setLevelTrim(trim);  // within its limit: the table's range is that limit
  }
  if (mask & (1u << kGroupRc)) {
    RcSettings& rc = app.rc_settings_;
    rc.protocol = static_cast<RcProtocol>(v[kParamRcProtocol]);
    rc.pwm_channels = static_cast<uint8_t>(v[kParamRcChannels]);
    tc::flashWordCopy(kRcMapWords, static_cast<uint8_t>(v[kParamRcMap]), rc.map, sizeof rc.map);
    rc.mode_channel = v[kParamRcModeChannel] == 0 ? 0xFF : static_cast<uint8_t>(v[kParamRcModeChannel] - 1);
    rc.default_mode = static_cast<FlightMode>(v[kParamFlightMode]);
    app.applyReceiverSettings();
  }
  if (mask & (1u << kGroupSticks)) {
    StickSettings st = app.stick_command_.settings();
    st.max_angle_deg = static_cast<uint8_t>(v[kParamStickAngleDeg]);
    st.max_rate_dps = static_cast<uint16_t>(v[kParamStickRateDps]);
    st.max_yaw_rate_dps = static_cast<uint16_t>(v[kParamStickYawDps]);
    app.stick_command_.setSettings(st);
  }
  if (mask & ((1u << kGroupMixer) | (1u << kGroupMode))) app.schedule();  // the budget follows them
  return mode_taken;
}

SavedState Params::onReset(ParamValues& v) {
  const tc::ParamTable t = table();
  SavedState s;
  tc::defaultParams(t.row, t.rows, v);
  tc::ParamsRecord rec;
  s.where = tc::readParams<hal::Eeprom>(rec);
  if (s.where.status != tc::DecodeStatus::kOk) {
    s.how = s.where.hosts == 0 ? ParamLoad::kNoRoom : ParamLoad::kNone;
    return s;
  }
  s.layout = rec.layout;
  if (rec.layout != t.layout) {
    s.how = ParamLoad::kOtherLayout;
    return s;
  }
  s.check = tc::decodeParams(t.row, t.rows, rec.payload, rec.length, v);
  if (!s.check.ok()) {
    s.how = ParamLoad::kCannotBeRight;
    s.value[0] = v[s.check.row];
    s.value[1] = s.check.row + 1 < kParamCount ? v[s.check.row + 1] : 0;
    tc::defaultParams(t.row, t.rows, v);  // v keeps nothing of a record that cannot be right
    return s;
  }
  s.how = ParamLoad::kLoaded;
  return s;
}

// Armed, a console line may start only early in the frame (fly_rules.hpp, consoleMayStart):
// the EEPROM read and the capture each take a few hundred microseconds, so a frame that came
// due meanwhile is served between them.
uint8_t Params::unsaved(const FlyApp& app, ParamValues& now, ParamValues& reset, SavedState* state) {
  serve();
  const SavedState s = onReset(reset);
  if (state != nullptr) *state = s;
  serve();
  capture(app, now);
  serve();
  uint8_t n = 0;
  for (uint8_t i = 0; i < kParamCount; ++i) n = static_cast<uint8_t>(n + (now[i] != reset[i]));
  return n;
}

void Params::load(FlyApp& app) {
  ParamValues v;
  const SavedState s = onReset(v);
  // fly starts with the defaults; a record is applied whole.
  const bool mode_taken = s.how == ParamLoad::kLoaded ? apply(app, v, kAllGroups) : true;
  params_view::loaded(s);
  if (!mode_taken) params_view::modeNotTaken(app, v);
}

void Params::list(const FlyApp& app) {
  ParamValues now, reset;
  unsaved(app, now, reset);
  for (uint8_t i = 0; i < kParamCount; ++i) params_view::row(i, now[i], reset[i], false);
}

void Params::get(const FlyApp& app, const char* name) {
  const int8_t i = tc::findParam(table().row, kParamCount, name);
  if (i < 0) {
    params_view::unknown(name);
    return;
  }
  ParamValues now, reset;
  unsaved(app, now, reset);
  params_view::row(static_cast<uint8_t>(i), now[i], reset[i], true);
}

// long: each refusal in the order a user meets them, then the one group applied
void Params::set(FlyApp& app, const char* name, const char* text) {
  const tc::ParamTable t = table();
  const int8_t found = tc::findParam(t.row, t.rows, name);
  if (found < 0) {
    params_view::unknown(name);
    return;
  }
  const uint8_t i = static_cast<uint8_t>(found);
  const tc::ParamDef d = tc::paramRow(t.row, i);
  if (app.flight_.armed && (d.flags & tc::kParamLive) == 0) {
    params_view::armedRefused(d);
    return;
  }
  int32_t value = 0;
  const tc::ParamParse parsed = tc::parseParamValue(d, text, value);
  if (parsed != tc::ParamParse::kOk) {
    params_view::valueRefused(d, parsed, text);
    return;
  }
  ParamValues v;
  capture(app, v);
  v[i] = value;
  const tc::ParamCheck check = tc::checkParams(t.row, t.rows, v);
  if (!check.ok()) {
    params_view::ruleBroken(check, v);
    return;
  }
  if (!apply(app, v, static_cast<uint16_t>(1u << d.group))) {
    params_view::modeNotTaken(app, v);
    return;
  }
  ParamValues reset;
  unsaved(app, v, reset);
  params_view::row(i, v[i], reset[i], false);
}

void Params::save(FlyApp& app) {
  if (app.refuseWhileArmed()) return;
  const tc::ParamTable t = table();
  ParamValues v;
  capture(app, v);
  const tc::ParamCheck check = tc::checkParams(t.row, t.rows, v);
  if (!check.ok()) {  // a setting command let a value through that the table refuses
    params_view::ruleBroken(check, v);
    return;
  }
  tc::ParamsRecord rec;
  rec.layout = t.layout;
  rec.length = tc::paramPayloadBytes(t.row, t.rows);
  tc::encodeParams(t.row, t.rows, v, rec.payload);
  params_view::saved(tc::writeParams<ServedEeprom>(rec));
}

void Params::reload(FlyApp& app) {
  if (app.refuseWhileArmed()) return;
  ParamValues v;
  const SavedState s = onReset(v);
  const bool mode_taken = apply(app, v, kAllGroups);  // the record, or the defaults
  params_view::loaded(s);
  if (!mode_taken) params_view::modeNotTaken(app, v);
}

void Params::defaults(FlyApp& app) {
  if (app.refuseWhileArmed()) return;
  const tc::ParamTable t = table();
  ParamValues v;
  tc::defaultParams(t.row, t.rows, v);
  apply(app, v, kAllGroups);  // mode force: always taken
  params_view::defaultsSet();
}

void Params::sayStatus(const FlyApp& app) {
  ParamValues now, reset;
  SavedState s;
  const uint8_t n = unsaved(app, now, reset, &s);
  params_view::status(n, s);
}

}  // namespace fly

// fly's receiver input alone (firmware/fly/rc_input.hpp, linking fly_rc and the flight types
// only): PPM sums and one-pulse-per-channel PWM decoded from timestamped edges as hal::Rc queues
// them, noise rejected and counted, and the sticks mapped to a setpoint and the arming gestures.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "rc_input.hpp"

namespace {

using namespace fly;

// Edges of a PPM frame on bit 0 from `t` (0.5 us ticks): a 400 us separator before each channel
// and after the last, idle high (or low: `inverted`), then the sync gap to `frame_us`.
std::vector<RcEdge> ppm(uint16_t& t, const std::vector<uint16_t>& us, bool inverted = false,
                        uint32_t frame_us = 22500) {
  const uint8_t idle = inverted ? 0 : 1, pulse = inverted ? 1 : 0;
  std::vector<RcEdge> e;
  uint32_t used = 0;
  for (std::size_t i = 0; i <= us.size(); ++i) {
    e.push_back({pulse, t});
    e.push_back({idle, static_cast<uint16_t>(t + 800)});
    if (i == us.size()) break;
    t = static_cast<uint16_t>(t + 2 * us[i]);
    used += us[i];
  }
  t = static_cast<uint16_t>(t + 2 * (frame_us - used));
  return e;
}

// Feeds edges; the frames they completed.
std::vector<RcFrame> feed(RcDecoder& d, const std::vector<RcEdge>& edges) {
  std::vector<RcFrame> out;
  for (const RcEdge& e : edges)
    if (d.edge(e)) out.push_back(d.frame());
  return out;
}

const std::vector<uint16_t> kSticks = {1520, 1480, 1100, 1900, 1000, 2000, 1500, 1234};

TEST(RcPpm, EightChannelsDecodeToTheMicrosecondAfterTheFirstSyncGap) {
  RcDecoder d;
  d.begin(RcProtocol::kPpm, 0);
  uint16_t t = 100;
  // a frame ends at the gap after it, seen at the next frame's first edge: the first frame's
  // edges find the gap before the second, the second frame is decoded at the third's start
  EXPECT_TRUE(feed(d, ppm(t, kSticks)).empty());
  EXPECT_TRUE(feed(d, ppm(t, kSticks)).empty());
  const std::vector<RcFrame> f = feed(d, ppm(t, kSticks));
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].channels, 8);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(f[0].us[i], kSticks[i]) << i;
  EXPECT_EQ(d.rejectedPulses(), 0u);
  EXPECT_EQ(d.badFrames(), 0u);
}

TEST(RcPpm, EitherPolarityAndTheTimersWrapDecodeAlike) {
  RcDecoder d;
  d.begin(RcProtocol::kPpm, 0);
  uint16_t t = 60000;  // the 16-bit ticks wrap inside the second frame
  std::vector<RcFrame> f;
  for (int k = 0; k < 5; ++k)
    for (const RcFrame& x : feed(d, ppm(t, kSticks, true))) f.push_back(x);
  ASSERT_EQ(f.size(), 3u);
  for (const RcFrame& x : f)
    for (int i = 0; i < 8; ++i) EXPECT_EQ(x.us[i], kSticks[i]);
}

TEST(RcPpm, AGlitchOrAnOutOfRangePulseRejectsTheWholeFrameAndIsCounted) {
  RcDecoder d;
  d.begin(RcProtocol::kPpm, 0);
  uint16_t t = 0;
  feed(d, ppm(t, kSticks));
  feed(d, ppm(t, kSticks));
  // a spike in channel 3: an extra separator 300 us into it (two short pulses instead of one)
  std::vector<RcEdge> noisy = ppm(t, kSticks);
  const uint16_t at = static_cast<uint16_t>(noisy[4].ticks + 600);
  noisy.insert(noisy.begin() + 6, {RcEdge{0, at}, RcEdge{1, static_cast<uint16_t>(at + 20)}});
  EXPECT_EQ(feed(d, noisy).size(), 1u) << "the clean frame before it";
  // a receiver's own failsafe: one channel at 2500 us
  std::vector<uint16_t> wild = kSticks;
  wild[2] = 2500;
  EXPECT_TRUE(feed(d, ppm(t, wild)).empty()) << "the noisy frame: not flown";
  EXPECT_GE(d.rejectedPulses(), 1u);
  EXPECT_EQ(d.badFrames(), 1u);
  EXPECT_TRUE(feed(d, ppm(t, kSticks)).empty()) << "the wild frame: not flown";
  EXPECT_EQ(d.badFrames(), 2u);
  // then a clean frame flies again
  EXPECT_EQ(feed(d, ppm(t, kSticks)).size(), 1u);
  EXPECT_EQ(d.frame().us[2], 1100);
}

TEST(RcPpm, ASpikeThatSplitsAChannelInTwoValidHalvesIsABadFrame) {
  // a six-channel receiver: a split channel makes seven channels, every pulse in range
  const std::vector<uint16_t> six = {1500, 1500, 2000, 1500, 1000, 1000};
  RcDecoder d;
  d.begin(RcProtocol::kPpm, 0);
  uint16_t t = 0;
  feed(d, ppm(t, six));
  feed(d, ppm(t, six));
  ASSERT_EQ(feed(d, ppm(t, six)).size(), 1u);
  std::vector<RcEdge> split = ppm(t, six);  // a spike 1000 us into channel 3 (2000 us)
  const uint16_t at = static_cast<uint16_t>(split[4].ticks + 2000);
  split.insert(split.begin() + 6, {RcEdge{0, at}, RcEdge{1, static_cast<uint16_t>(at + 20)}});
  EXPECT_EQ(feed(d, split).size(), 1u) << "the clean frame before it";
  EXPECT_TRUE(feed(d, ppm(t, six)).empty()) << "seven channels where the receiver sends six: not flown";
  EXPECT_EQ(d.badFrames(), 1u);
  EXPECT_EQ(d.rejectedPulses(), 0u) << "both halves were in range";
  EXPECT_EQ(feed(d, ppm(t, six)).size(), 1u);
  EXPECT_EQ(d.frame().channels, 6);
  // a receiver set up anew with eight channels: flown from the second frame that has them
  feed(d, ppm(t, kSticks));
  EXPECT_TRUE(feed(d, ppm(t, kSticks)).empty()) << "the first eight-channel frame";
  EXPECT_EQ(feed(d, ppm(t, kSticks)).size(), 1u);
  EXPECT_EQ(d.frame().channels, 8);
}

TEST(RcPpm, FewerThanFourChannelsIsNoFrame) {
  RcDecoder d;
  d.begin(RcProtocol::kPpm, 0);
  uint16_t t = 0;
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(feed(d, ppm(t, {1500, 1500, 1000})).empty());
  EXPECT_EQ(d.badFrames(), 1u);
}

// A PPM decoder that has flown a frame of kSticks; `t` where the next frame starts.
void decodingPpm(RcDecoder& d, uint16_t& t) {
  d.begin(RcProtocol::kPpm, 0);
  t = 0;
  feed(d, ppm(t, kSticks));
  feed(d, ppm(t, kSticks));
  ASSERT_EQ(feed(d, ppm(t, kSticks)).size(), 1u);
}

TEST(RcPpm, AfterAGapNoIntervalIsTakenAcrossIt) {
  RcDecoder d;
  uint16_t t;
  decodingPpm(d, t);
  d.gap();  // edges were lost (hal::Rc's queue was full)
  t = static_cast<uint16_t>(t + 12345);
  EXPECT_TRUE(feed(d, ppm(t, kSticks)).empty()) << "waits for a sync gap again";
  EXPECT_TRUE(feed(d, ppm(t, kSticks)).empty());
  EXPECT_EQ(feed(d, ppm(t, kSticks)).size(), 1u);
  EXPECT_EQ(d.badFrames(), 0u);
}

TEST(RcPpm, AfterASilenceTheNextWholeFrameFliesAndOneCutShortIsBad) {
  RcDecoder d;
  uint16_t t;
  decodingPpm(d, t);
  // a dropout: the line idle for more than kRcEdgeGapMs, which is a sync gap
  d.silence();
  t = static_cast<uint16_t>(t + 12345);
  EXPECT_TRUE(feed(d, ppm(t, kSticks)).empty()) << "the frame ends at the next one's first edge";
  EXPECT_EQ(feed(d, ppm(t, kSticks)).size(), 1u) << "the first frame after the silence flies";
  // the line back in the middle of a frame (a loose plug): three channels short, not flown
  d.silence();
  t = static_cast<uint16_t>(t + 12345);
  std::vector<RcEdge> cut = ppm(t, kSticks);
  cut.erase(cut.begin(), cut.begin() + 6);
  EXPECT_TRUE(feed(d, cut).empty());
  EXPECT_TRUE(feed(d, ppm(t, kSticks)).empty()) << "five channels where the receiver sends eight";
  EXPECT_EQ(d.badFrames(), 1u);
  EXPECT_EQ(feed(d, ppm(t, kSticks)).size(), 1u);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(d.frame().us[i], kSticks[i]) << i;
  // inverted polarity comes back alike
  d.silence();
  t = static_cast<uint16_t>(t + 12345);
  EXPECT_TRUE(feed(d, ppm(t, kSticks, true)).empty());
  EXPECT_EQ(feed(d, ppm(t, kSticks, true)).size(), 1u);
  EXPECT_EQ(d.badFrames(), 1u);
}

// PWM: channel i on bit i, one after another.
std::vector<RcEdge> pwm(uint16_t& t, const std::vector<uint16_t>& us, uint8_t& level) {
  std::vector<RcEdge> e;
  for (std::size_t i = 0; i < us.size(); ++i) {
    const uint8_t bit = static_cast<uint8_t>(1u << i);
    level |= bit;
    e.push_back({level, t});
    t = static_cast<uint16_t>(t + 2 * us[i]);
    level &= static_cast<uint8_t>(~bit);
    e.push_back({level, t});
    t = static_cast<uint16_t>(t + 100);
  }
  t = static_cast<uint16_t>(t + 2 * 10000);
  return e;
}

TEST(RcPwm, AFrameIsEveryWiredChannelsNewPulseAndAGlitchIsRejected) {
  RcDecoder d;
  d.begin(RcProtocol::kPwm, 5);
  uint8_t level = 0;
  uint16_t t = 7;
  const std::vector<uint16_t> five(kSticks.begin(), kSticks.begin() + 5);
  EXPECT_FALSE(d.edge({0, 1})) << "the first edge only tells the pins' levels";
  std::vector<RcFrame> f = feed(d, pwm(t, five, level));
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].channels, 5);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(f[0].us[i], five[i]) << i;
  // a 300 us glitch on channel 2 instead of its pulse: no frame until it brings a good one
  std::vector<uint16_t> glitch = five;
  glitch[1] = 300;
  EXPECT_TRUE(feed(d, pwm(t, glitch, level)).empty());
  EXPECT_EQ(d.rejectedPulses(), 1u);
  f = feed(d, pwm(t, five, level));
  EXPECT_EQ(f.size(), 1u) << "channel 2's good pulse completes it";
}

TEST(RcSticks, TheMapsPutEachFunctionOnItsChannel) {
  char map[5];
  ASSERT_TRUE(parseRcMap("taer", map));
  EXPECT_STREQ(map, "TAER");
  EXPECT_EQ(rcChannelOf(map, 'T'), 0);
  EXPECT_EQ(rcChannelOf(map, 'R'), 3);
  for (const char* bad : {"AETT", "AET", "AETRX", "ABCD", ""}) EXPECT_FALSE(parseRcMap(bad, map)) << bad;
  RcSettings s;
  ASSERT_TRUE(parseRcMap("TAER", s.map));
  RcFrame f;
  f.channels = 4;
  const uint16_t us[4] = {1200, 1700, 1400, 1510};  // T A E R
  for (int i = 0; i < 4; ++i) f.us[i] = us[i];
  const Sticks k = sticksOf(f, s);
  EXPECT_EQ(k.throttle_us, 1200);
  EXPECT_EQ(k.roll, 190) << "200 us right, less the deadband";
  EXPECT_EQ(k.pitch, -90);
  EXPECT_EQ(k.yaw, 0) << "within the deadband";
  EXPECT_EQ(k.mode, FlightMode::kAngle) << "no fifth channel: the default";
}

TEST(RcSticks, ThrottleLowWithYawRightArmsAndYawLeftDisarms) {
  Sticks s;
  s.throttle_us = 1050;
  s.yaw = 490;
  EXPECT_EQ(stickGesture(s), StickGesture::kArm);
  s.yaw = -490;
  EXPECT_EQ(stickGesture(s), StickGesture::kDisarm);
  s.yaw = 300;
  EXPECT_EQ(stickGesture(s), StickGesture::kNone) << "not far enough";
  s.yaw = 490;
  s.throttle_us = 1300;
  EXPECT_EQ(stickGesture(s), StickGesture::kNone) << "throttle not low";
}

TEST(RcSticks, FullSticksAskForTheSettingsAnglesAndRates) {
  StickCommand c;
  StickSettings st;
  st.max_angle_deg = 30;
  st.max_rate_dps = 200;
  st.max_yaw_rate_dps = 100;
  c.setSettings(st);
  Sticks s;
  s.roll = 490;      // full right
  s.pitch = -245;    // half back
  s.yaw = 490;       // full right: nose right
  SetpointQ q = c.setpoint(s);
  EXPECT_NEAR(q.roll * kRadPerAngleUnit / kRadPerDeg, 30.0, 0.01);
  EXPECT_NEAR(q.pitch * kRadPerAngleUnit / kRadPerDeg, -15.0, 0.01);
  EXPECT_NEAR(q.rate[2] * kRadPerRateUnit / kRadPerDeg, -100.0, 0.05) << "yaw right is a negative rate";
  s.mode = FlightMode::kRate;
  q = c.setpoint(s);
  EXPECT_EQ(q.mode, FlightMode::kRate);
  EXPECT_NEAR(q.rate[0] * kRadPerRateUnit / kRadPerDeg, 200.0, 0.1);
  EXPECT_EQ(q.roll, 0);
  EXPECT_EQ(StickCommand::throttleShareQ10(1000), 0);
  EXPECT_EQ(StickCommand::throttleShareQ10(1500), 512);
  EXPECT_EQ(StickCommand::throttleShareQ10(2100), 1024);
}

}  // namespace

#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <string>

#include "thrustcal/eeprom_codec.hpp"

namespace {

using tc::DecodeStatus;
using tc::MotorCalibration;

// RAM EEPROM with read-before-write like hal::Eeprom: only changed bytes count as writes.
// `write_budget` simulates power loss: once it reaches 0, further changes are lost.
struct RamEeprom {
  static uint8_t bytes[4096];
  static uint32_t writes;
  static int32_t write_budget;  // < 0: unlimited
  static uint8_t readByte(uint16_t addr) { return bytes[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) {
    if (bytes[addr] == value) return;
    if (write_budget == 0) return;
    if (write_budget > 0) --write_budget;
    bytes[addr] = value;
    ++writes;
  }
  static void erase() {
    std::memset(bytes, 0xFF, sizeof bytes);
    writes = 0;
    write_budget = -1;
  }
};
uint8_t RamEeprom::bytes[4096];
uint32_t RamEeprom::writes = 0;
int32_t RamEeprom::write_budget = -1;

void fill(tc::ForceCurveBase& curve, uint16_t start_mv, uint16_t pwm_at_1g_us, uint16_t max_grams, uint8_t seed) {
  curve.start_mv = start_mv;
  curve.pwm_at_1g_us = pwm_at_1g_us;
  for (uint16_t i = 0; i < curve.stepCount(); ++i)
    curve.steps()[i] = (i + 1u < max_grams) ? static_cast<uint8_t>((i * 7u + seed) % 3u) : tc::kUnreachable;
  curve.finalize();
}

MotorCalibration sampleCalibration(uint8_t seed = 1) {
  MotorCalibration cal;
  fill(cal.first, 12450, 1105, 480, seed);
  fill(cal.second, 10900, 1130, 410, static_cast<uint8_t>(seed + 1));
  cal.sag.base_pwm_us = 1080;
  for (uint8_t i = 0; i < tc::kSagBins; ++i) cal.sag.offset_mv[i] = static_cast<int16_t>(i * 40 + (i ? seed * 10 : 0));
  return cal;
}

void expectSameCalibration(const MotorCalibration& a, const MotorCalibration& b) {
  EXPECT_EQ(a.first.start_mv, b.first.start_mv);
  EXPECT_EQ(a.second.start_mv, b.second.start_mv);
  EXPECT_EQ(a.first.maxGrams(), b.first.maxGrams());
  EXPECT_EQ(a.second.maxGrams(), b.second.maxGrams());
  for (uint16_t g = 0; g <= 500; ++g) {
    ASSERT_EQ(a.first.pwmForGrams(g), b.first.pwmForGrams(g)) << g;
    ASSERT_EQ(a.second.pwmForGrams(g), b.second.pwmForGrams(g)) << g;
  }
  EXPECT_EQ(a.sag.base_pwm_us, b.sag.base_pwm_us);
  for (uint8_t i = 0; i < tc::kSagBins; ++i) EXPECT_EQ(a.sag.offset_mv[i], b.sag.offset_mv[i]) << int(i);
}

class EepromCodec : public ::testing::Test {
 protected:
  void SetUp() override { RamEeprom::erase(); }
};

TEST_F(EepromCodec, RecordRoundTripsThroughTheEeprom) {
  // given
  const MotorCalibration written = sampleCalibration();
  // when
  tc::writeRecord<RamEeprom>(2, written);
  MotorCalibration read;
  const DecodeStatus status = tc::readRecord<RamEeprom>(2, read);
  // then
  ASSERT_EQ(status, DecodeStatus::kOk);
  EXPECT_TRUE(read.isCalibrated());
  EXPECT_TRUE(read.hasSecondCurve());
  expectSameCalibration(read, written);
}

TEST_F(EepromCodec, RecordsSitAt1024ByteSlotsWithTheDocumentedLayout) {
  // given
  const MotorCalibration cal = sampleCalibration();
  // when
  tc::writeRecord<RamEeprom>(1, cal);
  // then
  const uint8_t* r = RamEeprom::bytes + 1024;
  EXPECT_EQ(RamEeprom::bytes[1023], 0xFF) << "slot 0 untouched";
  EXPECT_EQ(RamEeprom::bytes[2048], 0xFF) << "slot 2 untouched";
  EXPECT_EQ(r[0], tc::kLayoutVersion1);
  EXPECT_EQ(r[1] | (r[2] << 8), 12450);
  EXPECT_EQ(r[3] | (r[4] << 8), 1105);
  EXPECT_EQ(r[5], cal.first.steps()[0]);
  EXPECT_EQ(r[503], cal.first.steps()[498]);
  EXPECT_EQ(r[504] | (r[505] << 8), 1080);
  EXPECT_EQ(static_cast<int8_t>(r[506 + 12]), tc::codec_detail::sagToByte(cal.sag.offset_mv[12]));
  EXPECT_EQ(r[519] | (r[520] << 8), 10900);
  EXPECT_EQ(r[521] | (r[522] << 8), 1130);
  EXPECT_EQ(r[523], cal.second.steps()[0]);
  EXPECT_EQ(r[1022] | (r[1023] << 8), tc::crc16CcittFalse(r, 1022));
}

TEST_F(EepromCodec, FourSlotsAreIndependent) {
  const MotorCalibration cals[] = {sampleCalibration(1), sampleCalibration(2), sampleCalibration(3)};
  tc::writeRecord<RamEeprom>(0, cals[0]);
  tc::writeRecord<RamEeprom>(1, cals[1]);
  tc::writeRecord<RamEeprom>(3, cals[2]);
  MotorCalibration read;
  ASSERT_EQ(tc::readRecord<RamEeprom>(0, read), DecodeStatus::kOk);
  expectSameCalibration(read, cals[0]);
  ASSERT_EQ(tc::readRecord<RamEeprom>(1, read), DecodeStatus::kOk);
  expectSameCalibration(read, cals[1]);
  EXPECT_EQ(tc::readRecord<RamEeprom>(2, read), DecodeStatus::kErased);
  ASSERT_EQ(tc::readRecord<RamEeprom>(3, read), DecodeStatus::kOk);
  expectSameCalibration(read, cals[2]);
}

TEST_F(EepromCodec, ErasedRecordDecodesAsNotCalibrated) {
  // given a previously decoded calibration in the output
  MotorCalibration out = sampleCalibration();
  // when
  const DecodeStatus status = tc::readRecord<RamEeprom>(0, out);
  // then
  EXPECT_EQ(status, DecodeStatus::kErased);
  EXPECT_FALSE(out.isCalibrated());
  EXPECT_FALSE(out.hasSecondCurve());
  EXPECT_EQ(out.first.maxGrams(), 0);
}

TEST_F(EepromCodec, EraseRecordWritesOnlyTheVersionByte) {
  tc::writeRecord<RamEeprom>(1, sampleCalibration());
  RamEeprom::writes = 0;
  tc::eraseRecord<RamEeprom>(1);
  EXPECT_EQ(RamEeprom::writes, 1u);
  MotorCalibration out;
  EXPECT_EQ(tc::readRecord<RamEeprom>(1, out), DecodeStatus::kErased);
}

TEST_F(EepromCodec, UnknownLayoutVersionIsRejected) {
  for (uint8_t version : {0, 2, 0x7F, 0xFE}) {
    tc::writeRecord<RamEeprom>(0, sampleCalibration());
    RamEeprom::bytes[0] = version;
    MotorCalibration out;
    EXPECT_EQ(tc::readRecord<RamEeprom>(0, out), DecodeStatus::kBadVersion) << int(version);
    EXPECT_FALSE(out.isCalibrated());
  }
}

TEST_F(EepromCodec, EverySingleBitFlipDecodesAsNotCalibratedNeverGarbage) {
  // given a good record in slot 3
  tc::writeRecord<RamEeprom>(3, sampleCalibration());
  uint8_t* record = RamEeprom::bytes + 3 * 1024;
  uint32_t flips = 0;
  for (uint16_t byte = 0; byte < tc::kRecordBytes; ++byte) {
    for (uint8_t bit = 0; bit < 8; ++bit) {
      // when one bit flips
      record[byte] ^= static_cast<uint8_t>(1u << bit);
      MotorCalibration out;
      const DecodeStatus status = tc::readRecord<RamEeprom>(3, out);
      record[byte] ^= static_cast<uint8_t>(1u << bit);
      // then: a flipped version byte is an unknown version, anything else a CRC mismatch
      const DecodeStatus expected = byte == 0 ? DecodeStatus::kBadVersion : DecodeStatus::kBadCrc;
      ASSERT_EQ(status, expected) << "byte " << byte << " bit " << int(bit);
      ASSERT_FALSE(out.isCalibrated());
      ASSERT_FALSE(out.hasSecondCurve());
      ++flips;
    }
  }
  EXPECT_EQ(flips, 8192u);
}

TEST_F(EepromCodec, PowerLossWhileWritingLeavesACorruptRecordNotAMixedOne) {
  for (bool over_old_record : {false, true}) {
    // given an erased slot or one holding an older calibration, and the number of bytes a
    // complete write of the new record would change
    RamEeprom::erase();
    if (over_old_record) tc::writeRecord<RamEeprom>(0, sampleCalibration(1));
    uint8_t before[4096];
    std::memcpy(before, RamEeprom::bytes, sizeof before);
    RamEeprom::writes = 0;
    tc::writeRecord<RamEeprom>(0, sampleCalibration(2));
    const int32_t changed = static_cast<int32_t>(RamEeprom::writes);
    ASSERT_GT(changed, 10);
    const int32_t budgets[] = {0, 1, 2, 3, changed / 4, changed / 2, changed - 3, changed - 2, changed - 1};
    for (int32_t budget : budgets) {
      // when power fails after `budget` of those bytes
      std::memcpy(RamEeprom::bytes, before, sizeof before);
      RamEeprom::write_budget = budget;
      tc::writeRecord<RamEeprom>(0, sampleCalibration(2));
      RamEeprom::write_budget = -1;
      // then the slot reads as the old record (nothing written yet) or as not calibrated
      MotorCalibration out;
      const DecodeStatus status = tc::readRecord<RamEeprom>(0, out);
      if (budget == 0 && over_old_record) {
        ASSERT_EQ(status, DecodeStatus::kOk);
        expectSameCalibration(out, sampleCalibration(1));
      } else {
        EXPECT_NE(status, DecodeStatus::kOk) << "old record " << over_old_record << ", " << budget << " of " << changed;
        EXPECT_FALSE(out.isCalibrated());
      }
    }
  }
}

TEST_F(EepromCodec, RewritingAnIdenticalRecordWritesNothing) {
  // given
  const MotorCalibration cal = sampleCalibration();
  tc::writeRecord<RamEeprom>(0, cal);
  EXPECT_GT(RamEeprom::writes, 900u) << "the first write changes most erased bytes";
  // when
  RamEeprom::writes = 0;
  tc::writeRecord<RamEeprom>(0, cal);
  // then
  EXPECT_EQ(RamEeprom::writes, 0u);
}

TEST_F(EepromCodec, ChangingOneGramRewritesThatByteAndTheCrcOnly) {
  MotorCalibration cal = sampleCalibration();
  tc::writeRecord<RamEeprom>(0, cal);
  RamEeprom::writes = 0;
  cal.first.steps()[100] = static_cast<uint8_t>(cal.first.steps()[100] + 1);
  cal.first.finalize();
  tc::writeRecord<RamEeprom>(0, cal);
  EXPECT_GE(RamEeprom::writes, 2u);
  EXPECT_LE(RamEeprom::writes, 3u);
  MotorCalibration out;
  ASSERT_EQ(tc::readRecord<RamEeprom>(0, out), DecodeStatus::kOk);
  expectSameCalibration(out, cal);
}

TEST_F(EepromCodec, AbsentSecondCurveIsStoredAsAbsentWhateverItsStaleBytes) {
  // given a second curve removed by zeroing its start voltage only
  MotorCalibration cal = sampleCalibration();
  cal.second.start_mv = 0;
  // when
  tc::writeRecord<RamEeprom>(0, cal);
  MotorCalibration out;
  ASSERT_EQ(tc::readRecord<RamEeprom>(0, out), DecodeStatus::kOk);
  // then
  EXPECT_FALSE(out.hasSecondCurve());
  EXPECT_EQ(out.second.pwm_at_1g_us, 0);
  EXPECT_EQ(RamEeprom::bytes[523], tc::kUnreachable);
  EXPECT_EQ(RamEeprom::bytes[521] | (RamEeprom::bytes[522] << 8), 0);
}

TEST_F(EepromCodec, ImplausibleContentWithAGoodCrcIsBadContent) {
  struct Row {
    const char* what;
    void (*spoil)(MotorCalibration&);
  };
  const Row rows[] = {
      {"no first curve", [](MotorCalibration& c) { c.first.start_mv = 0; }},
      {"first start voltage 2.999 V", [](MotorCalibration& c) { c.first.start_mv = 2999; }},
      {"first start voltage 30.001 V", [](MotorCalibration& c) { c.first.start_mv = 30001; }},
      {"first curve 1 g at 499 us", [](MotorCalibration& c) { c.first.pwm_at_1g_us = 499; }},
      {"first curve 1 g at 2501 us", [](MotorCalibration& c) { c.first.pwm_at_1g_us = 2501; }},
      {"first curve without a 1 g PWM", [](MotorCalibration& c) { c.first.pwm_at_1g_us = 0; }},
      {"first curve ends above 2500 us", [](MotorCalibration& c) { c.first.steps()[300] = 254; c.first.steps()[301] = 254; c.first.steps()[302] = 254; c.first.steps()[303] = 254; c.first.steps()[304] = 254; }},
      {"a step after the end marker", [](MotorCalibration& c) { c.first.steps()[490] = 1; }},
      {"sag base PWM 0", [](MotorCalibration& c) { c.sag.base_pwm_us = 0; }},
      {"sag offset of bin 0 not 0", [](MotorCalibration& c) { c.sag.offset_mv[0] = 30; }},
      {"second start voltage 1 V", [](MotorCalibration& c) { c.second.start_mv = 1000; }},
      {"second curve 1 g at 3000 us", [](MotorCalibration& c) { c.second.pwm_at_1g_us = 3000; }},
      {"second curve step after the end marker", [](MotorCalibration& c) { c.second.steps()[450] = 0; }},
  };
  for (const auto& r : rows) {
    // given a record written with one impossible value (its CRC is right)
    RamEeprom::erase();
    MotorCalibration cal = sampleCalibration();
    r.spoil(cal);
    tc::writeRecord<RamEeprom>(0, cal);
    // when
    MotorCalibration out;
    const DecodeStatus status = tc::readRecord<RamEeprom>(0, out);
    // then
    EXPECT_EQ(status, DecodeStatus::kBadContent) << r.what;
    EXPECT_FALSE(out.isCalibrated()) << r.what;
    EXPECT_FALSE(out.hasSecondCurve()) << r.what;
  }
}

TEST(EepromCodecSag, OffsetsAreStoredInTenMillivoltUnitsRoundedAndSaturated) {
  struct Row {
    int16_t mv;
    int8_t stored;
  };
  const Row rows[] = {{0, 0},      {4, 0},       {5, 1},       {-4, 0},      {-5, -1},
                      {14, 1},     {15, 2},      {550, 55},    {1270, 127},  {1275, 127},
                      {2000, 127}, {-1280, -128}, {-1285, -128}, {-32768, -128}, {32767, 127}};
  for (const auto& r : rows) EXPECT_EQ(tc::codec_detail::sagToByte(r.mv), r.stored) << r.mv;
}

TEST(EepromCodecText, EveryStatusHasItsOwnText) {
  const DecodeStatus all[] = {DecodeStatus::kOk, DecodeStatus::kErased, DecodeStatus::kBadVersion,
                              DecodeStatus::kBadCrc, DecodeStatus::kBadContent};
  std::set<std::string> texts;
  for (DecodeStatus s : all) {
    ASSERT_NE(tc::decodeStatusText(s), nullptr);
    texts.insert(tc::decodeStatusText(s));
  }
  EXPECT_EQ(texts.size(), 5u);
  EXPECT_STREQ(tc::decodeStatusText(DecodeStatus::kOk), "ok");
  EXPECT_STREQ(tc::decodeStatusText(static_cast<DecodeStatus>(99)), "unknown status");
}

}  // namespace

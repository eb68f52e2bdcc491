// The v2 record with the motor's dynamics (issue 26; record_v2.hpp, dynamics.hpp): 128 bytes
// under one CRC, a record without them byte for byte as before, the plausibility rule, and a
// flipped bit anywhere refused. The power cuts: eeprom_store_test.cpp, whose models carry them.
#include <gtest/gtest.h>

#include <string>

#include "test_records.hpp"
#include "thrustcal/plausibility.hpp"
#include "thrustcal/record_v2.hpp"

namespace {

using Ee = tc_test::CutEeprom;

struct Text {  // printPlausibility's output on the host
  std::string s;
  void flash(const char* t) { s += t; }
  void fixed(int32_t v, uint8_t decimals) {
    std::string d = std::to_string(v < 0 ? -v : v);
    if (decimals) {
      while (d.size() <= decimals) d.insert(d.begin(), '0');
      d.insert(d.end() - decimals, '.');
    }
    s += (v < 0 ? "-" : "") + d;
  }
};

TEST(RecordV2Dynamics, AModelWithDynamicsRoundTripsIn128BytesUnderOneCrc) {
  // given
  const tc::ModelV2 plain = tc_test::motorModel(1.8, 1097, 12.4);
  const tc::ModelV2 with = tc_test::withDynamics(plain);
  uint8_t a[tc::kRecordV2MaxBytes], b[tc::kRecordV2MaxBytes];
  // when
  tc::serializeModelV2(plain, 7, a);
  tc::serializeModelV2(with, 7, b);
  // then: the plain image is the 115-byte layout, the other 128 bytes with the flag
  EXPECT_EQ(tc::recordV2Length(a[5]), tc::kRecordV2Bytes);
  EXPECT_EQ(tc::recordV2Length(b[5]), tc::kRecordV2DynBytes);
  EXPECT_EQ(b[5] & tc::kV2HasDynamics, tc::kV2HasDynamics);
  for (uint16_t i = 0; i < tc::kRecordV2CrcOffset; ++i) {
    if (i != 5) EXPECT_EQ(a[i], b[i]) << "byte " << i;
  }
  tc::ModelV2 back;
  uint16_t seq = 0;
  ASSERT_EQ(tc::parseModelV2(b, back, seq), tc::DecodeStatus::kOk);
  EXPECT_EQ(seq, 7);
  EXPECT_TRUE(tc_test::sameModel(back, with));
  EXPECT_EQ(back.flags & tc::kV2HasDynamics, 0) << "the flag is the record's, not the model's";
  ASSERT_EQ(tc::parseModelV2(a, back, seq), tc::DecodeStatus::kOk);
  EXPECT_FALSE(back.dynamics.isPresent());
}

TEST(RecordV2Dynamics, EverySingleBitFlipIsRefused) {
  const tc::ModelV2 with = tc_test::withDynamics(tc_test::motorModel(1.8, 1097, 12.4));
  uint8_t image[tc::kRecordV2MaxBytes];
  tc::serializeModelV2(with, 3, image);
  for (uint16_t i = 0; i < tc::kRecordV2DynBytes; ++i) {
    for (uint8_t bit = 0; bit < 8; ++bit) {
      uint8_t flipped[tc::kRecordV2MaxBytes];
      std::copy(image, image + tc::kRecordV2MaxBytes, flipped);
      flipped[i] ^= static_cast<uint8_t>(1u << bit);
      tc::ModelV2 out;
      uint16_t seq = 0;
      EXPECT_NE(tc::parseModelV2(flipped, out, seq), tc::DecodeStatus::kOk) << "byte " << i << " bit " << int(bit);
    }
  }
}

TEST(RecordV2Dynamics, DynamicsThatCannotBeRightAreRefusedByTheDecoderAndTheWriter) {
  struct Case {
    const char* name;
    void (*spoil)(tc::MotorDynamics&);
    tc::Implausible rule;
    const char* text;
  };
  const Case cases[] = {
      {"a time constant of 2 ms", [](tc::MotorDynamics& d) { d.up_hi_01ms = 20; }, tc::Implausible::kDynamics,
       "motor dynamics out of range (2.0 ms; allowed 5.0..2000.0 ms)"},
      {"a spin-down of 3 s", [](tc::MotorDynamics& d) { d.down_lo_01ms = 30000; }, tc::Implausible::kDynamics,
       "motor dynamics out of range (3000.0 ms; allowed 5.0..2000.0 ms)"},
      {"nine points", [](tc::MotorDynamics& d) { d.points = 9; }, tc::Implausible::kMalformed,
       "malformed record (fields outside the layout)"},
      {"lightest above heaviest", [](tc::MotorDynamics& d) { d.lo_dg = 5000; }, tc::Implausible::kMalformed,
       "malformed record (fields outside the layout)"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    tc::ModelV2 m = tc_test::withDynamics(tc_test::motorModel(1.8, 1097, 12.4));
    c.spoil(m.dynamics);
    // the decoder: a right CRC does not make it flyable
    uint8_t image[tc::kRecordV2MaxBytes];
    tc::serializeModelV2(m, 1, image);
    tc::ModelV2 out;
    uint16_t seq = 0;
    tc::Plausibility why;
    EXPECT_EQ(tc::parseModelV2(image, out, seq, tc::RecordLimits(), &why), tc::DecodeStatus::kBadContent);
    EXPECT_EQ(why.rule, c.rule);
    Text t;
    tc::printPlausibility(why, t);
    EXPECT_EQ(t.s, c.text);
    // the writer: nothing written
    Ee::erase();
    EXPECT_NE(tc::writeModelV2<Ee>(0, m).status, tc::WriteV2Status::kWritten);
    EXPECT_EQ(Ee::physical_writes, 0u);
  }
}

TEST(RecordV2Dynamics, TheLawPassesThroughItsStoredEndsAndExtrapolatesWithinBounds) {
  const tc::MotorDynamics d = tc_test::withDynamics(tc_test::motorModel(1.8, 1097, 12.4)).dynamics;
  EXPECT_NEAR(d.tauUpS(80.0f), 0.0920f, 1e-5f);
  EXPECT_NEAR(d.tauUpS(440.0f), 0.0740f, 1e-5f);
  EXPECT_NEAR(d.tauDownS(80.0f), 0.0950f, 1e-5f);
  // in between, 1/tau linear in sqrt(F)
  const float s = (std::sqrt(200.0f) - std::sqrt(80.0f)) / (std::sqrt(440.0f) - std::sqrt(80.0f));
  EXPECT_NEAR(1.0f / d.tauUpS(200.0f), (1 - s) / 0.092f + s / 0.074f, 1e-3f);
  // beyond the points it goes on, within the record's 5 ms .. 2 s
  EXPECT_GT(d.tauUpS(10.0f), 0.092f);
  EXPECT_LT(d.tauUpS(2000.0f), 0.074f);
  EXPECT_LE(d.tauUpS(0.0f), 2.0f);
  EXPECT_EQ(tc::MotorDynamics().tauUpS(100.0f), 0.0f);
}

}  // namespace

// Saved parameters (thrustcal/param_table.hpp, param_store.hpp): a table's values as text and as
// the record's payload, and the record's two copies cut after every byte of a save and of the
// thesis store that moves them, against a RAM EEPROM.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "test_records.hpp"
#include "thrustcal/eeprom_store.hpp"
#include "thrustcal/param_store.hpp"
#include "thrustcal/param_table.hpp"

using tc_test::CutEeprom;
using Ee = CutEeprom;

namespace {

// A table with every kind of row: widths 1, 2 and 4, signed, decimals, words, 0 as off, a
// below-next pair.
const char kGain[] = "gain";
const char kTrim[] = "trim_mg";
const char kShape[] = "shape";
const char kHover[] = "hover_us";
const char kVmin[] = "volt_min_mv";
const char kVmax[] = "volt_max_mv";
const char kBig[] = "big_um";
const char kMnm[] = "mN m/rad";
const char kMg[] = "mg";
const char kUs[] = "us";
const char kMv[] = "mV";
const char kUm[] = "um";
const char kNone[] = "";
const char kShapes[] = "plus|x|seesaw";
const char kHelp[] = "a row";
const tc::ParamDef kRows[] = {
    {kGain, kMnm, nullptr, kHelp, 0, 10000, 800, 2, 0, 0, 0},
    {kTrim, kMg, nullptr, kHelp, -1000, 1000, 0, 2, 1, 0, 0},
    {kShape, kNone, kShapes, kHelp, 0, 2, 1, 1, 0, 0, 0},
    {kHover, kUs, nullptr, kHelp, 1001, 2000, 0, 2, 0, tc::kParamZeroIsOff, 0},
    {kVmin, kMv, nullptr, kHelp, 0, 26000, 0, 2, 0, tc::kParamBelowNext, 0},
    {kVmax, kMv, nullptr, kHelp, 0, 26000, 0, 2, 0, 0, 0},
    {kBig, kUm, nullptr, kHelp, -100000, 100000, 14900, 4, 0, 0, 0},
};
constexpr uint8_t kN = sizeof kRows / sizeof kRows[0];

struct TextCase {
  uint8_t row;
  const char* text;
  int32_t value;
};

TEST(ParamTable, ValuesReadAsTheyAreWrittenWithTheirDecimalsAndWords) {
  const TextCase cases[] = {
      {0, "800", 800},   {0, "0", 0},           {1, "39.1", 391},      {1, "-0.5", -5},
      {1, "0.0", 0},     {1, "-100.0", -1000},  {2, "seesaw", 2},      {2, "plus", 0},
      {3, "0", 0},       {3, "1480", 1480},     {6, "-100000", -100000}, {6, "14900", 14900},
  };
  for (const TextCase& c : cases) {
    int32_t v = 12345;
    EXPECT_EQ(tc::parseParamValue(kRows[c.row], c.text, v), tc::ParamParse::kOk) << c.text;
    EXPECT_EQ(v, c.value) << c.text;
    char out[tc::kParamTextMax];
    tc::formatParamValue(kRows[c.row], c.value, out);
    EXPECT_STREQ(out, c.text);
  }
  int32_t v = 0;
  EXPECT_EQ(tc::parseParamValue(kRows[1], "39", v), tc::ParamParse::kOk);
  EXPECT_EQ(v, 390) << "fewer decimals than the row's are zeros";
}

TEST(ParamTable, TextThatIsNotAValueOfTheRowIsRefusedWithItsReason) {
  struct Bad {
    uint8_t row;
    const char* text;
    tc::ParamParse why;
  };
  const Bad cases[] = {
      {0, "", tc::ParamParse::kNotANumber},      {0, "-", tc::ParamParse::kNotANumber},
      {0, "8e2", tc::ParamParse::kNotANumber},   {0, "80.0", tc::ParamParse::kNotANumber},
      {1, "39.12", tc::ParamParse::kNotANumber}, {1, "39.", tc::ParamParse::kNotANumber},
      {0, "10001", tc::ParamParse::kNotAllowed}, {0, "-1", tc::ParamParse::kNotAllowed},
      {1, "100.1", tc::ParamParse::kNotAllowed}, {3, "1000", tc::ParamParse::kNotAllowed},
      {0, "99999999999", tc::ParamParse::kNotAllowed},
      {2, "X", tc::ParamParse::kNotAWord},       {2, "plusx", tc::ParamParse::kNotAWord},
  };
  for (const Bad& c : cases) {
    int32_t v = 0;
    EXPECT_EQ(tc::parseParamValue(kRows[c.row], c.text, v), c.why) << "\"" << c.text << "\"";
  }
}

TEST(ParamTable, PayloadRoundTripsEveryWidthAndSign) {
  const int32_t values[kN] = {10000, -1000, 2, 2000, 9900, 12600, -99999};
  ASSERT_EQ(tc::paramPayloadBytes(kRows, kN), 2 + 2 + 1 + 2 + 2 + 2 + 4);
  uint8_t payload[tc::kParamPayloadMax];
  tc::encodeParams(kRows, kN, values, payload);
  int32_t back[kN] = {};
  EXPECT_TRUE(tc::decodeParams(kRows, kN, payload, tc::paramPayloadBytes(kRows, kN), back).ok());
  for (uint8_t i = 0; i < kN; ++i) EXPECT_EQ(back[i], values[i]) << static_cast<int>(i);
}

TEST(ParamTable, APayloadThatCannotBeRightNamesTheRowAtFault) {
  int32_t values[kN];
  tc::defaultParams(kRows, kN, values);
  EXPECT_TRUE(tc::checkParams(kRows, kN, values).ok()) << "the defaults are allowed";
  uint8_t payload[tc::kParamPayloadMax];
  // given: a value outside its range, written by someone else
  values[3] = 1000;  // hover: neither 0 nor 1001..2000
  tc::encodeParams(kRows, kN, values, payload);
  int32_t back[kN];
  tc::ParamCheck c = tc::decodeParams(kRows, kN, payload, tc::paramPayloadBytes(kRows, kN), back);
  EXPECT_EQ(c.fault, tc::ParamFault::kOutOfRange);
  EXPECT_EQ(c.row, 3);
  // given: the minimum not below the maximum (which is not 0)
  tc::defaultParams(kRows, kN, values);
  values[4] = 12600;
  values[5] = 12600;
  tc::encodeParams(kRows, kN, values, payload);
  c = tc::decodeParams(kRows, kN, payload, tc::paramPayloadBytes(kRows, kN), back);
  EXPECT_EQ(c.fault, tc::ParamFault::kNotBelowNext);
  EXPECT_EQ(c.row, 4);
  values[5] = 0;  // off: any minimum
  EXPECT_TRUE(tc::checkParams(kRows, kN, values).ok());
  // given: another table's length
  c = tc::decodeParams(kRows, kN, payload, 14, back);
  EXPECT_EQ(c.fault, tc::ParamFault::kBadLength);
  EXPECT_EQ(back[0], 800) << "the defaults";
}

TEST(ParamTable, NamesAreFoundWholeAndExactly) {
  EXPECT_EQ(tc::findParam(kRows, kN, "hover_us"), 3);
  EXPECT_EQ(tc::findParam(kRows, kN, "hover"), -1);
  EXPECT_EQ(tc::findParam(kRows, kN, "hover_usx"), -1);
  EXPECT_EQ(tc::findParam(kRows, kN, "GAIN"), -1);
}

// ---- the record ----------------------------------------------------------------------------

tc::ParamsRecord recordOf(const int32_t (&values)[kN], uint8_t layout = 1) {
  tc::ParamsRecord r;
  r.layout = layout;
  r.length = tc::paramPayloadBytes(kRows, kN);
  tc::encodeParams(kRows, kN, values, r.payload);
  return r;
}

class ParamStore : public ::testing::Test {
 protected:
  void SetUp() override { Ee::erase(); }
  const int32_t a_[kN] = {800, 0, 1, 0, 0, 0, 14900};
  const int32_t b_[kN] = {900, 391, 0, 1480, 9900, 12600, 15000};
  const int32_t c_[kN] = {1200, -45, 2, 1500, 0, 0, 20000};
};

TEST_F(ParamStore, NothingSavedReadsErasedAndWhatIsSavedReadsBackFromAlternateCopies) {
  tc::ParamsRecord got;
  tc::ParamsRead r = tc::readParams<Ee>(got);
  EXPECT_EQ(r.status, tc::DecodeStatus::kErased);
  EXPECT_EQ(r.hosts, 4);
  tc::ParamsWrite w = tc::writeParams<Ee>(recordOf(a_));
  EXPECT_EQ(w.status, tc::ParamsWriteStatus::kWritten);
  EXPECT_EQ(w.host, 3) << "the highest host, as the divider";
  EXPECT_EQ(w.copy, 0);
  r = tc::readParams<Ee>(got);
  ASSERT_EQ(r.status, tc::DecodeStatus::kOk);
  EXPECT_TRUE(got.samePayload(recordOf(a_)));
  EXPECT_EQ(tc::writeParams<Ee>(recordOf(a_)).status, tc::ParamsWriteStatus::kUnchanged);
  w = tc::writeParams<Ee>(recordOf(b_));
  EXPECT_EQ(w.copy, 1);
  EXPECT_EQ(w.sequence, 2);
  EXPECT_EQ(tc::writeParams<Ee>(recordOf(c_)).copy, 0);
  r = tc::readParams<Ee>(got);
  EXPECT_TRUE(got.samePayload(recordOf(c_)));
  EXPECT_EQ(r.sequence, 3);
}

TEST_F(ParamStore, ARecordThatDoesNotFitItsRoomIsNotWritten) {
  tc::ParamsRecord r = recordOf(a_);
  r.length = 0;
  EXPECT_EQ(tc::writeParams<Ee>(r).status, tc::ParamsWriteStatus::kInvalid);
  r.length = tc::kParamPayloadMax + 1;
  EXPECT_EQ(tc::writeParams<Ee>(r).status, tc::ParamsWriteStatus::kInvalid);
  EXPECT_EQ(Ee::update_calls, 0u);
}

TEST_F(ParamStore, TheNewestCopyIsReadEvenFromAnotherLayoutNeverAnOlderOneInstead) {
  tc::writeParams<Ee>(recordOf(a_, 1));
  tc::writeParams<Ee>(recordOf(b_, 2));
  tc::ParamsRecord got;
  ASSERT_EQ(tc::readParams<Ee>(got).status, tc::DecodeStatus::kOk);
  EXPECT_EQ(got.layout, 2) << "the image judges the layout; the store does not skip it";
}

TEST_F(ParamStore, ASaveCutAfterEveryByteLeavesTheOldOrTheNewRecordWhole) {
  tc::writeParams<Ee>(recordOf(a_));
  tc::writeParams<Ee>(recordOf(b_));  // copies A and B both used
  const std::vector<uint8_t> before = Ee::image();
  Ee::restore(before);  // counts from here
  tc::writeParams<Ee>(recordOf(c_));
  const int32_t total = static_cast<int32_t>(Ee::update_calls);
  EXPECT_EQ(total, tc::kParamsHeaderBytes + tc::paramPayloadBytes(kRows, kN) + 2);
  for (int16_t torn : {-1, 0x00, 0xA5}) {
    for (int32_t k = 0; k <= total; ++k) {
      Ee::restore(before);
      Ee::budget = k;
      Ee::torn = torn;
      tc::writeParams<Ee>(recordOf(c_));
      Ee::budget = -1;
      tc::ParamsRecord got;
      ASSERT_EQ(tc::readParams<Ee>(got).status, tc::DecodeStatus::kOk) << k;
      const bool is_new = got.samePayload(recordOf(c_));
      EXPECT_TRUE(is_new || got.samePayload(recordOf(b_))) << "cut after " << k << ", torn " << torn;
      EXPECT_EQ(is_new, k == total) << "the new record wins with its last CRC byte; cut after " << k;
    }
  }
}

TEST_F(ParamStore, AThesisRecordOverTheirHostMovesThemFirstAtEveryByte) {
  // given: parameters in slot 3, a v2 model in slot 1
  tc::writeModelV2<Ee>(1, tc_test::motorModel(1.8, 1097, 12.4));
  ASSERT_EQ(tc::writeParams<Ee>(recordOf(b_)).host, 3);
  const tc::MotorCalibration cal_a = tc_test::thesisRecord(tc_test::SyntheticMotor(), 12.4, 10.9);
  const std::vector<uint8_t> before = Ee::image();
  Ee::restore(before);
  tc::MotorCalibration cal = cal_a;
  const tc::StoreReport rep = tc::storeRecordV1<Ee>(3, cal);
  EXPECT_EQ(rep.status, tc::StoreStatus::kStored);
  EXPECT_EQ(rep.params, tc::ParamsMove::kMoved);
  const int32_t total = static_cast<int32_t>(Ee::update_calls);
  // when: the store is cut after every write
  for (int32_t k = 0; k <= total; ++k) {
    Ee::restore(before);
    Ee::budget = k;
    cal = cal_a;
    tc::storeRecordV1<Ee>(3, cal);
    Ee::budget = -1;
    // then: the parameters read whole at every cut
    tc::ParamsRecord got;
    ASSERT_EQ(tc::readParams<Ee>(got).status, tc::DecodeStatus::kOk) << k;
    EXPECT_TRUE(got.samePayload(recordOf(b_))) << k;
  }
  tc::ParamsRecord got;
  EXPECT_EQ(tc::readParams<Ee>(got).host, 2) << "moved to the next host down";
}

TEST_F(ParamStore, WithFourThesisRecordsThereIsNoRoomAndTheLastHostsRecordIsDropped) {
  // given: thesis records in slots 0..2, the parameters in slot 3 (the last host)
  const tc::MotorCalibration cal_a = tc_test::thesisRecord(tc_test::SyntheticMotor(), 12.4, 10.9);
  for (uint8_t s = 0; s < 3; ++s) {
    tc::MotorCalibration cal = cal_a;
    tc::writeRecord<Ee>(s, cal);
  }
  ASSERT_EQ(tc::writeParams<Ee>(recordOf(b_)).status, tc::ParamsWriteStatus::kWritten);
  // when: a thesis record takes slot 3
  tc::MotorCalibration cal = cal_a;
  const tc::StoreReport rep = tc::storeRecordV1<Ee>(3, cal);
  // then: stored, the parameters said dropped, none read, and none can be saved
  EXPECT_EQ(rep.status, tc::StoreStatus::kStored);
  EXPECT_EQ(rep.params, tc::ParamsMove::kDropped);
  tc::ParamsRecord got;
  const tc::ParamsRead r = tc::readParams<Ee>(got);
  EXPECT_NE(r.status, tc::DecodeStatus::kOk);
  EXPECT_EQ(r.hosts, 0);
  EXPECT_EQ(tc::writeParams<Ee>(recordOf(a_)).status, tc::ParamsWriteStatus::kNoRoom);
}

TEST_F(ParamStore, AThesisStoreElsewhereLeavesThemWhereTheyAre) {
  ASSERT_EQ(tc::writeParams<Ee>(recordOf(b_)).host, 3);
  tc::MotorCalibration cal = tc_test::thesisRecord(tc_test::SyntheticMotor(), 12.4, 10.9);
  EXPECT_EQ(tc::storeRecordV1<Ee>(0, cal).params, tc::ParamsMove::kNone);
  tc::ParamsRecord got;
  EXPECT_EQ(tc::readParams<Ee>(got).host, 3);
}

}  // namespace

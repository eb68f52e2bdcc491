// The v2 record: two copies per slot, sequence + CRC, power-fail-safe writes, fault
// injection, wrap-around, write counts, and the v1/v2 slot loader. Storage is a RAM EEPROM
// that counts physical writes and can stop accepting writes (a power cut) after any byte.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "synthetic_motor.hpp"
#include "test_records.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/record_v2.hpp"

using tc_test::SyntheticMotor;

namespace {

using Ee = tc_test::CutEeprom;

tc::ModelV2 motorModel(double exponent, double start_us, double rest_v) {
  const tc::ModelV2 m = tc_test::motorModel(exponent, start_us, rest_v);
  EXPECT_TRUE(m.isPresent());
  return m;
}

bool sameModel(const tc::ModelV2& a, const tc::ModelV2& b) {
  return tc_test::sameModel(a, b) && a.inv_step_q22 == b.inv_step_q22 &&
         a.rest_recip_q27 == b.rest_recip_q27 && a.max_force_dg == b.max_force_dg &&
         a.start_q17_us == b.start_q17_us;
}

class RecordV2 : public ::testing::Test {
 protected:
  void SetUp() override { Ee::erase(); }
  const tc::ModelV2 m1 = motorModel(1.8, 1097, 12.4);
  const tc::ModelV2 m2 = motorModel(1.6, 1080, 12.4);
  const tc::ModelV2 m3 = motorModel(2.0, 1110, 11.1);
};

}  // namespace

static_assert(tc::kRecordV2Bytes <= 256, "record must stay within 256 bytes");

TEST_F(RecordV2, WrittenModelReadsBackIdenticalFromCopyA) {
  // when
  const tc::RecordV2Write w = tc::writeModelV2<Ee>(2, m1);
  tc::ModelV2 got;
  const tc::RecordV2Read r = tc::readModelV2<Ee>(2, got);
  // then
  EXPECT_EQ(w.status, tc::WriteV2Status::kWritten);
  EXPECT_EQ(w.copy, 0);
  EXPECT_EQ(w.sequence, 1);
  EXPECT_EQ(r.status, tc::DecodeStatus::kOk);
  EXPECT_EQ(r.copy, 0);
  EXPECT_EQ(r.copy_status[1], tc::DecodeStatus::kErased);
  EXPECT_TRUE(sameModel(got, m1));
  EXPECT_EQ(Ee::bytes[tc::slotAddress(2)], tc::kLayoutVersion2);
  EXPECT_LE(w.bytes_changed, tc::kRecordV2Bytes);
  EXPECT_EQ(w.bytes_changed, Ee::physical_writes);
}

TEST_F(RecordV2, SuccessiveWritesAlternateCopiesWithRisingSequence) {
  const tc::ModelV2* models[] = {&m1, &m2, &m3, &m1, &m2};
  const uint8_t expect_copy[] = {0, 1, 0, 1, 0};
  for (int i = 0; i < 5; ++i) {
    SCOPED_TRACE(i);
    const tc::RecordV2Write w = tc::writeModelV2<Ee>(0, *models[i]);
    ASSERT_EQ(w.status, tc::WriteV2Status::kWritten);
    EXPECT_EQ(w.copy, expect_copy[i]);
    EXPECT_EQ(w.sequence, i + 1);
    tc::ModelV2 got;
    const tc::RecordV2Read r = tc::readModelV2<Ee>(0, got);
    EXPECT_EQ(r.copy, expect_copy[i]);
    EXPECT_EQ(r.sequence, i + 1);
    EXPECT_TRUE(sameModel(got, *models[i]));
  }
}

TEST_F(RecordV2, RewritingTheStoredModelWritesNoByte) {
  tc::writeModelV2<Ee>(1, m1);
  tc::writeModelV2<Ee>(1, m2);
  const uint32_t before = Ee::physical_writes;
  // when
  const tc::RecordV2Write w = tc::writeModelV2<Ee>(1, m2);
  // then
  EXPECT_EQ(w.status, tc::WriteV2Status::kUnchanged);
  EXPECT_EQ(w.bytes_changed, 0);
  EXPECT_EQ(Ee::physical_writes, before);
  EXPECT_EQ(w.copy, 1);
}

TEST_F(RecordV2, TogglingBetweenTwoModelsWritesOnlySequenceAndCrc) {
  tc::writeModelV2<Ee>(1, m1);  // A, seq 1
  tc::writeModelV2<Ee>(1, m2);  // B, seq 2
  const uint32_t before = Ee::physical_writes;
  // when: m1 again goes to copy A, which holds m1 already
  const tc::RecordV2Write w = tc::writeModelV2<Ee>(1, m1);
  // then: at most the two sequence bytes and the two CRC bytes change
  EXPECT_EQ(w.status, tc::WriteV2Status::kWritten);
  EXPECT_EQ(w.copy, 0);
  EXPECT_LE(w.bytes_changed, 4);
  EXPECT_EQ(Ee::physical_writes - before, w.bytes_changed);
}

TEST_F(RecordV2, WritesStayInsideTheirSlot) {
  tc::writeModelV2<Ee>(1, m1);
  tc::writeModelV2<Ee>(1, m2);
  for (uint16_t a = 0; a < 4096; ++a) {
    if (a >= tc::slotAddress(1) && a < tc::slotAddress(2)) continue;
    ASSERT_EQ(Ee::bytes[a], 0xFF) << "byte " << a << " outside slot 1 changed";
  }
}

TEST_F(RecordV2, PowerLossAtAnyByteLeavesTheOldOrTheNewModel) {
  // Setups: what the slot held before the interrupted write.
  struct Setup {
    const char* name;
    std::vector<const tc::ModelV2*> history;  // written before, in order
  };
  const Setup setups[] = {
      {"old model in copy A only", {&m1}},
      {"old in B, older in A", {&m3, &m1}},
      {"old in A, older in B", {&m2, &m3, &m1}},
      {"older copy holds the new model", {&m2, &m1}},
  };
  const int16_t torn_values[] = {-1, 0x00, 0x5A, 0xFF};
  for (const Setup& s : setups) {
    for (int16_t torn : torn_values) {
      // The full write, for its length in updateByte calls.
      Ee::erase();
      for (const auto* m : s.history) tc::writeModelV2<Ee>(3, *m);
      const uint32_t calls_before = Ee::update_calls;
      ASSERT_EQ(tc::writeModelV2<Ee>(3, m2).status, tc::WriteV2Status::kWritten) << s.name;
      const int32_t total = static_cast<int32_t>(Ee::update_calls - calls_before);
      EXPECT_EQ(total, tc::kRecordV2Bytes);
      int olds = 0, news = 0;
      for (int32_t k = 0; k <= total; ++k) {
        SCOPED_TRACE(::testing::Message() << s.name << ", cut after " << k << " bytes, torn " << torn);
        // given: the slot as before
        Ee::erase();
        for (const auto* m : s.history) tc::writeModelV2<Ee>(3, *m);
        // when: power fails after k bytes of the new write (the k+1-th byte may be torn)
        Ee::budget = k;
        Ee::torn = torn;
        tc::writeModelV2<Ee>(3, m2);
        Ee::budget = -1;
        // then: the loader finds a whole model, the old one or the new one
        tc::ModelV2 v2;
        tc::MotorCalibration v1;
        const tc::SlotLoad load = tc::loadSlot<Ee>(3, v2, v1);
        ASSERT_EQ(load.layout, tc::SlotLayout::kModelV2);
        ASSERT_EQ(load.status, tc::DecodeStatus::kOk);
        const bool is_old = sameModel(v2, *s.history.back());
        const bool is_new = sameModel(v2, m2);
        ASSERT_TRUE(is_old || is_new);
        if (k == total) {
          EXPECT_TRUE(is_new);
        }
        olds += is_old && !is_new;
        news += is_new;
      }
      // the new model wins only with its last CRC byte
      EXPECT_GE(olds, total - 1) << s.name;
    }
  }
}

TEST_F(RecordV2, PowerLossDuringTheFirstWriteLeavesTheSlotUncalibratedOrNew) {
  for (int32_t k = 0; k <= tc::kRecordV2Bytes; ++k) {
    SCOPED_TRACE(k);
    Ee::erase();
    Ee::budget = k;
    Ee::torn = 0x33;
    tc::writeModelV2<Ee>(0, m1);
    Ee::budget = -1;
    tc::ModelV2 got;
    const tc::RecordV2Read r = tc::readModelV2<Ee>(0, got);
    if (r.status == tc::DecodeStatus::kOk) {
      EXPECT_TRUE(sameModel(got, m1));
    } else {
      EXPECT_FALSE(got.isPresent());
      EXPECT_LT(k, tc::kRecordV2Bytes);
    }
  }
}

TEST_F(RecordV2, BitFlipInEitherCopyLetsTheOtherCopyWin) {
  for (uint8_t bad_copy = 0; bad_copy < 2; ++bad_copy) {
    for (uint16_t offset = 0; offset < tc::kRecordV2Bytes; ++offset) {
      for (uint8_t bit : {0, 3, 7}) {
        SCOPED_TRACE(::testing::Message() << "copy " << int(bad_copy) << " byte " << offset << " bit " << int(bit));
        // given: m1 in copy A (seq 1), m2 in copy B (seq 2)
        Ee::erase();
        tc::writeModelV2<Ee>(0, m1);
        tc::writeModelV2<Ee>(0, m2);
        // when: one bit flips
        Ee::bytes[tc::copyAddressV2(0, bad_copy) + offset] ^= static_cast<uint8_t>(1u << bit);
        // then: the intact copy is loaded
        tc::ModelV2 got;
        const tc::RecordV2Read r = tc::readModelV2<Ee>(0, got);
        ASSERT_EQ(r.status, tc::DecodeStatus::kOk);
        EXPECT_EQ(r.copy, bad_copy ^ 1);
        EXPECT_TRUE(sameModel(got, bad_copy ? m1 : m2));
        EXPECT_NE(r.copy_status[bad_copy], tc::DecodeStatus::kOk);
      }
    }
  }
}

TEST_F(RecordV2, NewerSequenceWinsAcrossWrapAround) {
  struct Row {
    uint16_t seq_a, seq_b;
    uint8_t expect_copy;
  };
  const Row rows[] = {{1, 2, 1},          {2, 1, 0},          {0xFFFF, 0, 1}, {0, 0xFFFF, 0},
                      {0xFFFE, 0xFFFF, 1}, {0x7FFF, 0x8000, 1}, {7, 7, 0}};
  for (const Row& r : rows) {
    SCOPED_TRACE(::testing::Message() << r.seq_a << " vs " << r.seq_b);
    Ee::erase();
    uint8_t image[tc::kRecordV2Bytes];
    tc::serializeModelV2(m1, r.seq_a, image);
    std::memcpy(&Ee::bytes[tc::copyAddressV2(1, 0)], image, sizeof image);
    tc::serializeModelV2(m2, r.seq_b, image);
    std::memcpy(&Ee::bytes[tc::copyAddressV2(1, 1)], image, sizeof image);
    tc::ModelV2 got;
    const tc::RecordV2Read read = tc::readModelV2<Ee>(1, got);
    EXPECT_EQ(read.copy, r.expect_copy);
    EXPECT_TRUE(sameModel(got, r.expect_copy ? m2 : m1));
  }
}

TEST_F(RecordV2, WriteAfterSequence65535GoesOnWithZeroAndWins) {
  uint8_t image[tc::kRecordV2Bytes];
  tc::serializeModelV2(m1, 0xFFFF, image);
  std::memcpy(&Ee::bytes[tc::copyAddressV2(2, 0)], image, sizeof image);
  const tc::RecordV2Write w = tc::writeModelV2<Ee>(2, m3);
  EXPECT_EQ(w.copy, 1);
  EXPECT_EQ(w.sequence, 0);
  tc::ModelV2 got;
  EXPECT_EQ(tc::readModelV2<Ee>(2, got).copy, 1);
  EXPECT_TRUE(sameModel(got, m3));
}

TEST_F(RecordV2, DecodeFailuresAreReportedByTheMostTellingCopy) {
  uint8_t image[tc::kRecordV2Bytes];
  struct Row {
    const char* name;
    void (*corrupt)(uint8_t* a, uint8_t* b);
    tc::DecodeStatus expect;
  };
  const Row rows[] = {
      {"erased slot", [](uint8_t*, uint8_t*) {}, tc::DecodeStatus::kErased},
      {"foreign version byte", [](uint8_t* a, uint8_t*) { a[0] = 7; }, tc::DecodeStatus::kBadVersion},
      {"bad magic", [](uint8_t* a, uint8_t*) { a[0] = 2; a[1] = 0; }, tc::DecodeStatus::kBadVersion},
      {"corrupt copy B, foreign A", [](uint8_t* a, uint8_t* b) { a[0] = 9; b[0] = 2; b[1] = 0x5C; },
       tc::DecodeStatus::kBadCrc},
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(r.name);
    Ee::erase();
    r.corrupt(&Ee::bytes[tc::copyAddressV2(0, 0)], &Ee::bytes[tc::copyAddressV2(0, 1)]);
    tc::ModelV2 got;
    got.knots = 5;
    EXPECT_EQ(tc::readModelV2<Ee>(0, got).status, r.expect);
    EXPECT_FALSE(got.isPresent());
  }
  // CRC right, content impossible (40 knots)
  Ee::erase();
  tc::serializeModelV2(m1, 1, image);
  image[4] = 40;
  const uint16_t crc = tc::crc16CcittFalse(image, tc::kRecordV2CrcOffset);
  image[tc::kRecordV2CrcOffset] = static_cast<uint8_t>(crc & 0xFF);
  image[tc::kRecordV2CrcOffset + 1] = static_cast<uint8_t>(crc >> 8);
  std::memcpy(&Ee::bytes[tc::copyAddressV2(0, 0)], image, sizeof image);
  tc::ModelV2 got;
  EXPECT_EQ(tc::readModelV2<Ee>(0, got).status, tc::DecodeStatus::kBadContent);
  EXPECT_FALSE(got.isPresent());
}

TEST_F(RecordV2, InvalidModelIsNotWritten) {
  tc::ModelV2 bad = m1;
  bad.drive_512usmv[5] = 0;  // curve goes backwards
  const tc::RecordV2Write w = tc::writeModelV2<Ee>(0, bad);
  EXPECT_EQ(w.status, tc::WriteV2Status::kInvalidModel);
  EXPECT_EQ(Ee::physical_writes, 0u);
  EXPECT_EQ(tc::writeModelV2<Ee>(0, tc::ModelV2()).status, tc::WriteV2Status::kInvalidModel);
  EXPECT_STRNE(tc::writeV2StatusText(w.status), "unknown");
}

TEST_F(RecordV2, DeadEepromFailsTheReadBackAndKeepsTheOldModel) {
  tc::writeModelV2<Ee>(0, m1);
  Ee::budget = 0;  // every further write is lost
  const tc::RecordV2Write w = tc::writeModelV2<Ee>(0, m2);
  Ee::budget = -1;
  EXPECT_EQ(w.status, tc::WriteV2Status::kVerifyFailed);
  tc::ModelV2 got;
  EXPECT_EQ(tc::readModelV2<Ee>(0, got).status, tc::DecodeStatus::kOk);
  EXPECT_TRUE(sameModel(got, m1));
}

TEST_F(RecordV2, EraseClearsBothCopies) {
  tc::writeModelV2<Ee>(0, m1);
  tc::writeModelV2<Ee>(0, m2);
  tc::eraseModelV2<Ee>(0);
  tc::ModelV2 got;
  EXPECT_EQ(tc::readModelV2<Ee>(0, got).status, tc::DecodeStatus::kErased);
  EXPECT_EQ(tc::probeSlotLayout<Ee>(0), tc::SlotLayout::kNone);
}

// ---- the loader: v1 (thesis) or v2 ---------------------------------------------------------

namespace {

tc::MotorCalibration thesisCalibration() { return tc_test::thesisRecord(SyntheticMotor(), 12.4); }

}  // namespace

TEST_F(RecordV2, LoaderTellsV1FromV2AndLoadsEither) {
  // given: slot 0 v1, slot 1 v2, slot 2 erased, slot 3 v2 written over a v1 record
  const tc::MotorCalibration cal = thesisCalibration();
  tc::writeRecord<Ee>(0, cal);
  tc::writeModelV2<Ee>(1, m1);
  tc::writeRecord<Ee>(3, cal);
  tc::writeModelV2<Ee>(3, m2);
  struct Row {
    uint8_t slot;
    tc::SlotLayout layout;
    tc::DecodeStatus status;
    const tc::ModelV2* v2;
  };
  const Row rows[] = {
      {0, tc::SlotLayout::kThesisV1, tc::DecodeStatus::kOk, nullptr},
      {1, tc::SlotLayout::kModelV2, tc::DecodeStatus::kOk, &m1},
      {2, tc::SlotLayout::kNone, tc::DecodeStatus::kErased, nullptr},
      {3, tc::SlotLayout::kModelV2, tc::DecodeStatus::kOk, &m2},
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(int(r.slot));
    tc::ModelV2 v2;
    tc::MotorCalibration v1;
    const tc::SlotLoad load = tc::loadSlot<Ee>(r.slot, v2, v1);
    EXPECT_EQ(load.layout, r.layout) << tc::slotLayoutText(load.layout);
    EXPECT_EQ(load.status, r.status) << tc::decodeStatusText(load.status);
    EXPECT_EQ(tc::probeSlotLayout<Ee>(r.slot), r.layout);
    if (r.v2) {
      EXPECT_TRUE(sameModel(v2, *r.v2));
      EXPECT_FALSE(v1.isCalibrated());
    } else {
      EXPECT_FALSE(v2.isPresent());
    }
    if (r.layout == tc::SlotLayout::kThesisV1) {
      EXPECT_TRUE(v1.isCalibrated());
      EXPECT_EQ(v1.first.pwmForGrams(300), cal.first.pwmForGrams(300));
    }
  }
}

TEST_F(RecordV2, V1RecordWrittenOverV2WinsOnceCompleteAndV2SurvivesACutV1Write) {
  const tc::MotorCalibration cal = thesisCalibration();
  tc::writeModelV2<Ee>(0, m1);  // copy A
  tc::writeModelV2<Ee>(0, m2);  // copy B, newest
  // a v1 write cut after 300 bytes (before copy B at 512): the v2 model in B still loads
  Ee::budget = 300;
  tc::writeRecord<Ee>(0, cal);
  Ee::budget = -1;
  tc::ModelV2 v2;
  tc::MotorCalibration v1;
  tc::SlotLoad load = tc::loadSlot<Ee>(0, v2, v1);
  EXPECT_EQ(load.layout, tc::SlotLayout::kModelV2);
  EXPECT_EQ(load.status, tc::DecodeStatus::kOk);
  EXPECT_EQ(load.v2.copy, 1);
  EXPECT_TRUE(sameModel(v2, m2));
  // the full v1 write: v1 it is
  Ee::erase();
  tc::writeModelV2<Ee>(0, m1);
  tc::writeModelV2<Ee>(0, m2);
  tc::writeRecord<Ee>(0, cal);
  load = tc::loadSlot<Ee>(0, v2, v1);
  EXPECT_EQ(load.layout, tc::SlotLayout::kThesisV1);
  EXPECT_EQ(load.status, tc::DecodeStatus::kOk);
}

TEST(RecordV2Texts, EveryStatusAndLayoutHasItsOwnText) {
  const tc::WriteV2Status writes[] = {tc::WriteV2Status::kWritten, tc::WriteV2Status::kUnchanged,
                                      tc::WriteV2Status::kInvalidModel,
                                      tc::WriteV2Status::kVerifyFailed};
  for (auto a : writes)
    for (auto b : writes)
      if (a != b) {
        EXPECT_STRNE(tc::writeV2StatusText(a), tc::writeV2StatusText(b));
      }
  const tc::SlotLayout layouts[] = {tc::SlotLayout::kNone, tc::SlotLayout::kThesisV1,
                                    tc::SlotLayout::kModelV2};
  for (auto a : layouts)
    for (auto b : layouts)
      if (a != b) {
        EXPECT_STRNE(tc::slotLayoutText(a), tc::slotLayoutText(b));
      }
  EXPECT_STREQ(tc::writeV2StatusText(static_cast<tc::WriteV2Status>(99)), "unknown");
  EXPECT_STREQ(tc::slotLayoutText(static_cast<tc::SlotLayout>(99)), "unknown");
}

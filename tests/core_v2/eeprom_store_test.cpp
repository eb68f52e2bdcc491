// Power-fail-safe stores across the EEPROM (thrustcal/eeprom_store.hpp): v1 -> v2 and
// v2 -> v1 switches, erase, recovery and the board settings, each cut after every write
// (with a torn byte) and loaded the way read_run loads a slot.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "test_records.hpp"
#include "thrustcal/board_settings.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/eeprom_store.hpp"
#include "thrustcal/record_v2.hpp"

using tc_test::CutEeprom;
using tc_test::SyntheticMotor;
using Ee = CutEeprom;

namespace {

struct Calibration {  // what a slot should load: a v1 record, a v2 model, or nothing
  const tc::MotorCalibration* v1 = nullptr;
  const tc::ModelV2* v2 = nullptr;
};

struct Loaded {
  tc::SlotLoad load;
  tc::ModelV2 v2;
  std::unique_ptr<tc::MotorCalibration> v1 = std::make_unique<tc::MotorCalibration>();
};

Loaded loadSlot(uint8_t slot) {
  Loaded l;
  l.load = tc::loadSlot<Ee>(slot, l.v2, *l.v1);
  return l;
}

bool holds(const Loaded& l, const Calibration& c) {
  if (c.v2) return l.load.layout == tc::SlotLayout::kModelV2 && l.load.status == tc::DecodeStatus::kOk &&
                   tc_test::sameModel(l.v2, *c.v2);
  if (c.v1) return l.load.layout == tc::SlotLayout::kThesisV1 && l.load.status == tc::DecodeStatus::kOk &&
                   tc_test::sameCalibration(*l.v1, *c.v1);
  return l.load.status != tc::DecodeStatus::kOk;
}

std::string describe(const Loaded& l) {
  return std::string(tc::slotLayoutText(l.load.layout)) + " " + tc::decodeStatusText(l.load.status) +
         " copy " + std::to_string(l.load.v2.copy);
}

bool noValidSpare() {
  for (uint8_t s = 0; s < tc::kMotorSlots; ++s) {
    tc::ModelV2 m;
    if (tc::isSpareCopy(tc::readModelV2<Ee>(s, m).copy)) return false;
  }
  return true;
}

class EepromStore : public ::testing::Test {
 public:  // the setup tables below reach the models through the fixture
  void SetUp() override { Ee::erase(); }
  // m1 and m3 carry the motor's dynamics (128-byte copies), m2 none (115 bytes): every store
  // below moves dynamics through its copies and spares, or adds or drops them.
  const tc::ModelV2 m1 = tc_test::withDynamics(tc_test::motorModel(1.8, 1097, 12.4));
  const tc::ModelV2 m2 = tc_test::motorModel(1.6, 1080, 12.4);
  const tc::ModelV2 m3 = tc_test::withDynamics(tc_test::motorModel(2.0, 1110, 11.1), 4, 1.2);
  const tc::MotorCalibration cal_a = tc_test::thesisRecord(SyntheticMotor(), 12.4, 10.9);
  const tc::MotorCalibration cal_b = [] {
    SyntheticMotor m;
    m.full_at_9v9_g = 700;
    return tc_test::thesisRecord(m, 12.2, 10.5);
  }();

  void putV1(uint8_t slot, const tc::MotorCalibration& cal) {
    tc::MotorCalibration copy = cal;
    tc::writeRecord<Ee>(slot, copy);
  }
};

// The image a v1 -> v2 switch of motor 0 (to `m`) leaves when cut while its spare copy flies
// over the still-whole v1 record; empty when no cut point does.
std::vector<uint8_t> interruptedSwitch(const tc::ModelV2& m) {
  const std::vector<uint8_t> start = Ee::image();
  Ee::restore(start);  // counts from here
  tc::storeModelV2<Ee>(0, m);
  const int32_t total = static_cast<int32_t>(Ee::update_calls);
  for (int32_t k = 0; k <= total; ++k) {
    Ee::restore(start);
    Ee::budget = k;
    tc::storeModelV2<Ee>(0, m);
    Ee::budget = -1;
    tc::ModelV2 got;
    if (tc::isSpareCopy(tc::readModelV2<Ee>(0, got).copy) && Ee::bytes[0] == tc::kLayoutVersion1)
      return Ee::image();
  }
  return {};
}

// Runs `store` on `before` cut after every updateByte call (plus once complete), and checks
// that `slot` loads `old_cal` or `new_cal` (or, when `nothing_ok`, nothing), the other slots
// load what they loaded before, and that recovery (the next store's first step) changes
// neither. Returns how many cut points loaded the new calibration.
template <class Store>
int cutEverywhere(const std::vector<uint8_t>& before, uint8_t slot, Calibration old_cal,
                  Calibration new_cal, Store store, bool nothing_ok = false) {
  Ee::restore(before);
  Loaded others[tc::kMotorSlots];
  for (uint8_t s = 0; s < tc::kMotorSlots; ++s) others[s] = loadSlot(s);
  store();
  const int32_t total = static_cast<int32_t>(Ee::update_calls);
  EXPECT_GT(total, 0);
  EXPECT_TRUE(holds(loadSlot(slot), new_cal)) << "the complete store";
  EXPECT_TRUE(noValidSpare()) << "a complete store leaves no spare";
  int news = 0;
  bool seen_new = false;
  for (int16_t torn : {-1, 0x00, 0xA5}) {
    for (int32_t k = 0; k <= total; ++k) {
      SCOPED_TRACE(::testing::Message() << "cut after " << k << " of " << total << ", torn " << torn);
      Ee::restore(before);
      Ee::budget = k;
      Ee::torn = torn;
      store();
      Ee::budget = -1;
      Ee::torn = -1;
      const Loaded l = loadSlot(slot);
      const bool is_old = holds(l, old_cal);
      const bool is_new = holds(l, new_cal);
      const bool is_nothing = nothing_ok && l.load.status != tc::DecodeStatus::kOk;
      EXPECT_TRUE(is_old || is_new || is_nothing) << describe(l);
      if (torn < 0) {
        news += is_new;
        EXPECT_FALSE(seen_new && is_old && !is_new) << "went back to the old calibration";
        seen_new = seen_new || is_new;
      }
      for (uint8_t s = 0; s < tc::kMotorSlots; ++s) {
        if (s == slot) continue;
        const Loaded o = loadSlot(s);
        EXPECT_EQ(o.load.status, others[s].load.status) << "slot " << int(s);
        EXPECT_EQ(o.load.layout, others[s].load.layout) << "slot " << int(s);
        if (others[s].load.status == tc::DecodeStatus::kOk && o.load.layout == tc::SlotLayout::kModelV2) {
          EXPECT_TRUE(tc_test::sameModel(o.v2, others[s].v2)) << "slot " << int(s);
        }
        if (others[s].load.status == tc::DecodeStatus::kOk && o.load.layout == tc::SlotLayout::kThesisV1) {
          EXPECT_TRUE(tc_test::sameCalibration(*o.v1, *others[s].v1)) << "slot " << int(s);
        }
      }
      // recovery (the next store's first step) keeps what flies and leaves no spare
      tc::recoverSlots<Ee>();
      const Loaded r = loadSlot(slot);
      EXPECT_EQ(holds(r, old_cal), is_old) << describe(r);
      EXPECT_EQ(holds(r, new_cal), is_new) << describe(r);
      EXPECT_TRUE(noValidSpare());
    }
  }
  return news;
}

}  // namespace

TEST_F(EepromStore, V1ToV2SwitchLeavesTheOldThesisRecordOrTheNewModelAtEveryByte) {
  struct Setup {
    const char* name;
    void (*prepare)(EepromStore&);
  };
  const Setup setups[] = {
      {"other slots erased", [](EepromStore&) {}},
      {"slot 1 v2, slots 2 and 3 v1",
       [](EepromStore& t) {
         tc::writeModelV2<Ee>(1, t.m3);
         t.putV1(2, t.cal_b);
         t.putV1(3, t.cal_b);
       }},
      {"slots 1 and 3 v1, slot 2 erased after a v1 record",
       [](EepromStore& t) {
         t.putV1(1, t.cal_b);
         t.putV1(2, t.cal_b);
         t.putV1(3, t.cal_b);
         tc::eraseRecord<Ee>(2);  // stale v1 bytes left in the host
       }},
  };
  for (const Setup& s : setups) {
    SCOPED_TRACE(s.name);
    // given: motor 0 holds the thesis record
    Ee::erase();
    putV1(0, cal_a);
    s.prepare(*this);
    const std::vector<uint8_t> before = Ee::image();
    // when / then: store v2 cut after every byte
    const int news = cutEverywhere(before, 0, Calibration{&cal_a, nullptr}, Calibration{nullptr, &m1},
                                   [&] { tc::storeModelV2<Ee>(0, m1); });
    EXPECT_GT(news, tc::kRecordV2Bytes) << "the spare takes over before the own copy is written";
    // and the complete store says where the old record was kept
    Ee::restore(before);
    const tc::StoreReport rep = tc::storeModelV2<Ee>(0, m1);
    EXPECT_EQ(rep.status, tc::StoreStatus::kStored);
    EXPECT_FALSE(rep.unprotected);
    EXPECT_NE(rep.spare_host, tc::kNoSlot);
    EXPECT_EQ(rep.copy, 0);
    EXPECT_EQ(rep.sequence, 1);
  }
}

TEST_F(EepromStore, V2ToV1SwitchLeavesTheNewestModelOrTheNewThesisRecordNeverAnOlderModel) {
  struct Setup {
    const char* name;
    std::vector<const tc::ModelV2*> history;  // stores before, the last one newest
  };
  const Setup setups[] = {
      {"newest in copy B, older in A", {&m2, &m1}},
      {"newest in copy A, older in B", {&m3, &m2, &m1}},
  };
  for (const Setup& s : setups) {
    SCOPED_TRACE(s.name);
    Ee::erase();
    for (const auto* m : s.history) tc::writeModelV2<Ee>(0, *m);
    putV1(2, cal_b);  // the host is slot 1 or 3
    const std::vector<uint8_t> before = Ee::image();
    tc::MotorCalibration cal = cal_a;
    const int news = cutEverywhere(before, 0, Calibration{nullptr, s.history.back()},
                                   Calibration{&cal_a, nullptr}, [&] {
                                     cal = cal_a;
                                     tc::storeRecordV1<Ee>(0, cal);
                                   });
    EXPECT_GE(news, 1);
  }
}

TEST_F(EepromStore, SwitchWithNoSlotToSpareSaysItIsUnprotectedAndNeverFliesAnotherModel) {
  // given: thesis records in all four slots: no free byte in the EEPROM
  for (uint8_t s = 0; s < tc::kMotorSlots; ++s) putV1(s, s == 0 ? cal_a : cal_b);
  const std::vector<uint8_t> before = Ee::image();
  // when: motor 0 switches to v2, cut anywhere
  cutEverywhere(before, 0, Calibration{&cal_a, nullptr}, Calibration{nullptr, &m1},
                [&] { tc::storeModelV2<Ee>(0, m1); }, /*nothing_ok=*/true);
  // then: the complete store reports it
  Ee::restore(before);
  const tc::StoreReport rep = tc::storeModelV2<Ee>(0, m1);
  EXPECT_EQ(rep.status, tc::StoreStatus::kStored);
  EXPECT_TRUE(rep.unprotected);
  EXPECT_EQ(rep.spare_host, tc::kNoSlot);
  // and back to v1 the same way
  const std::vector<uint8_t> v2_image = Ee::image();
  tc::MotorCalibration cal = cal_b;
  cutEverywhere(v2_image, 0, Calibration{nullptr, &m1}, Calibration{&cal_b, nullptr}, [&] {
    cal = cal_b;
    tc::storeRecordV1<Ee>(0, cal);
  }, /*nothing_ok=*/true);
}

TEST_F(EepromStore, V2ToV2StoresKeepTheirGuaranteeThroughTheStoreFunction) {
  tc::writeModelV2<Ee>(3, m1);
  tc::writeModelV2<Ee>(3, m2);
  const std::vector<uint8_t> before = Ee::image();
  cutEverywhere(before, 3, Calibration{nullptr, &m2}, Calibration{nullptr, &m3},
                [&] { tc::storeModelV2<Ee>(3, m3); });
}

TEST_F(EepromStore, DynamicsAddedToAStoredModelAreThereWholeOrNotAtAllAtEveryByte) {
  // given: motor 2 holds m2 (no dynamics; copy A), as after `store v2`
  tc::writeModelV2<Ee>(2, m2);
  const tc::ModelV2 m2_dyn = tc_test::withDynamics(m2);
  // when: `dyn` stores the measured dynamics with the same model, cut after every byte
  const int news = cutEverywhere(Ee::image(), 2, Calibration{nullptr, &m2}, Calibration{nullptr, &m2_dyn},
                                 [&] { tc::storeModelV2<Ee>(2, m2_dyn); });
  // then: the new copy (B) wins with its last CRC byte, never a model with half its dynamics
  EXPECT_GE(news, 1);
  tc::ModelV2 got;
  EXPECT_EQ(tc::readModelV2<Ee>(2, got).copy, 1);
  EXPECT_TRUE(tc_test::sameModel(got, m2_dyn));
}

TEST_F(EepromStore, EraseCutAnywhereLeavesTheNewestModelOrNothingNeverTheOlderOne) {
  for (bool newest_in_b : {true, false}) {
    SCOPED_TRACE(newest_in_b ? "newest in B" : "newest in A");
    Ee::erase();
    tc::writeModelV2<Ee>(1, m1);
    tc::writeModelV2<Ee>(1, m2);
    if (!newest_in_b) tc::writeModelV2<Ee>(1, m3);
    const tc::ModelV2& newest = newest_in_b ? m2 : m3;
    cutEverywhere(Ee::image(), 1, Calibration{nullptr, &newest}, Calibration{}, [] { tc::eraseSlot<Ee>(1); });
  }
}

TEST_F(EepromStore, RecoveryCutAnywhereKeepsFlyingTheModelOfAnInterruptedSwitch) {
  // given: a v1 -> v2 switch of motor 0 cut right after its spare copy was complete
  putV1(0, cal_a);
  putV1(2, cal_b);
  const std::vector<uint8_t> interrupted = interruptedSwitch(m1);
  ASSERT_FALSE(interrupted.empty()) << "no cut point left the spare flying over the v1 record";
  EXPECT_TRUE(holds(loadSlot(0), Calibration{nullptr, &m1}));
  // when / then: recovery cut anywhere flies m1 throughout and settles it into copy A
  cutEverywhere(interrupted, 0, Calibration{nullptr, &m1}, Calibration{nullptr, &m1},
                [] { tc::recoverSlots<Ee>(); });
  Ee::restore(interrupted);
  tc::recoverSlots<Ee>();
  tc::ModelV2 m;
  EXPECT_EQ(tc::readModelV2<Ee>(0, m).copy, 0);
}

TEST_F(EepromStore, AThesisRecordOverAHostDoesNotLoseAnInterruptedSwitchOfAnotherMotor) {
  // given: motor 0's switch cut while its spare (in slot 1, the only host) flies
  putV1(0, cal_a);
  putV1(2, cal_b);
  putV1(3, cal_b);
  const std::vector<uint8_t> interrupted = interruptedSwitch(m1);
  ASSERT_FALSE(interrupted.empty());
  Ee::restore(interrupted);
  tc::ModelV2 m;
  ASSERT_EQ(tc::spareHost(0, tc::readModelV2<Ee>(0, m).copy), 1);
  // when: a thesis record is stored into slot 1
  tc::MotorCalibration cal = cal_b;
  EXPECT_EQ(tc::storeRecordV1<Ee>(1, cal).status, tc::StoreStatus::kStored);
  // then: motor 0 still flies the new model (settled into its own copy first)
  EXPECT_TRUE(holds(loadSlot(0), Calibration{nullptr, &m1}));
  EXPECT_TRUE(holds(loadSlot(1), Calibration{&cal_b, nullptr}));
}

TEST_F(EepromStore, ImplausibleRecordsAreNotStored) {
  tc::ModelV2 flat = m1;
  for (uint8_t k = 0; k < flat.knots; ++k) flat.drive_512usmv[k] = 0xFFFF;
  const tc::StoreReport v2 = tc::storeModelV2<Ee>(0, flat);
  EXPECT_EQ(v2.status, tc::StoreStatus::kImplausible);
  EXPECT_EQ(v2.why.rule, tc::Implausible::kFlat);
  tc::MotorCalibration cal = cal_a;
  cal.first.pwm_at_1g_us = 2500;
  const tc::StoreReport v1 = tc::storeRecordV1<Ee>(0, cal);
  EXPECT_EQ(v1.status, tc::StoreStatus::kImplausible);
  EXPECT_EQ(v1.why.rule, tc::Implausible::kPwmRange);
  for (uint8_t b : Ee::image()) ASSERT_EQ(b, 0xFF) << "nothing written";
}

// ---- board settings: the divider -------------------------------------------------------------

namespace {

tc::BoardSettings divider(uint32_t top, uint32_t bottom) {
  tc::BoardSettings s;
  s.divider_top_ohm = top;
  s.divider_bottom_ohm = bottom;
  return s;
}

// The settings with the bench's response (`dyn cell`): 3 stages of 30.0 ms.
tc::BoardSettings withBench(tc::BoardSettings s) {
  s.bench.stages = 3;
  s.bench.tau_01ms = 300;
  return s;
}

bool sameDivider(const tc::BoardSettings& a, const tc::BoardSettings& b) {
  return a.divider_top_ohm == b.divider_top_ohm && a.divider_bottom_ohm == b.divider_bottom_ohm &&
         a.bench == b.bench;
}

}  // namespace

TEST_F(EepromStore, TheDividerDefaultsToTheThesisAndReadsBackWhatWasStored) {
  tc::BoardSettings s = divider(1, 1);
  EXPECT_EQ(tc::readSettings<Ee>(s).status, tc::DecodeStatus::kErased);
  EXPECT_TRUE(s.isDefault());
  EXPECT_EQ(s.fullScaleMv(), 15638);
  const tc::SettingsWrite w = tc::storeSettings<Ee>(divider(100000, 22000));
  EXPECT_EQ(w.status, tc::SettingsWriteStatus::kWritten);
  EXPECT_EQ(w.host, 3) << "the highest slot first: motors are calibrated from 0 up";
  EXPECT_EQ(tc::readSettings<Ee>(s).status, tc::DecodeStatus::kOk);
  EXPECT_TRUE(sameDivider(s, divider(100000, 22000)));
  EXPECT_EQ(s.fullScaleMv(), 27727);
  EXPECT_EQ(s.recordLimits().maxMv(), tc::kPackMaxMv);
  EXPECT_EQ(s.batteryConfig().max_sane_mv, tc::kPackMaxMv);
  EXPECT_EQ(tc::storeSettings<Ee>(divider(100000, 22000)).status, tc::SettingsWriteStatus::kUnchanged);
}

TEST_F(EepromStore, DividersThatCannotBeRightAreRefused) {
  struct Row {
    uint32_t top, bottom;
    bool valid;
  };
  const Row rows[] = {{100000, 47000, true},  {0, 10000, true},        {100000, 0, false},
                      {100000, 99, false},    {20000000, 47000, false}, {1000000, 10000, false},
                      {100000, 22000, true},  {10000, 10000, true}};
  for (const Row& r : rows) {
    SCOPED_TRACE(::testing::Message() << r.top << "/" << r.bottom);
    EXPECT_EQ(divider(r.top, r.bottom).isValid(), r.valid);
    Ee::erase();
    EXPECT_EQ(tc::storeSettings<Ee>(divider(r.top, r.bottom)).status == tc::SettingsWriteStatus::kInvalid,
              !r.valid);
  }
}

TEST_F(EepromStore, DividerWriteCutAnywhereLeavesTheOldOrTheNewSetting) {
  // the divider alone (14 bytes), the bench's response added (17), then the divider changed
  // keeping the response (17 over 17)
  struct Case {
    tc::BoardSettings old_s, new_s;
    uint16_t bytes;
  };
  const Case cases[] = {
      {divider(100000, 33000), divider(56000, 10000), tc::kSettingsBytes},
      {divider(100000, 33000), withBench(divider(100000, 33000)), tc::kSettingsBenchBytes},
      {withBench(divider(100000, 33000)), withBench(divider(56000, 10000)), tc::kSettingsBenchBytes},
  };
  for (const Case& c : cases) {
    Ee::erase();
    tc::storeSettings<Ee>(divider(100000, 22000));
    tc::storeSettings<Ee>(c.old_s);  // copies A and B both used
    const std::vector<uint8_t> before = Ee::image();
    Ee::restore(before);  // counts from here
    tc::storeSettings<Ee>(c.new_s);
    const int32_t total = static_cast<int32_t>(Ee::update_calls);
    EXPECT_EQ(total, c.bytes);
    for (int16_t torn : {-1, 0x00, 0xA5}) {
      for (int32_t k = 0; k <= total; ++k) {
        Ee::restore(before);
        Ee::budget = k;
        Ee::torn = torn;
        tc::storeSettings<Ee>(c.new_s);
        Ee::budget = -1;
        tc::BoardSettings s;
        ASSERT_EQ(tc::readSettings<Ee>(s).status, tc::DecodeStatus::kOk);
        EXPECT_TRUE(sameDivider(s, c.old_s) || sameDivider(s, c.new_s))
            << k << " " << s.divider_top_ohm << "/" << s.divider_bottom_ohm;
        EXPECT_EQ(sameDivider(s, c.new_s), k == total);
      }
    }
  }
}

TEST_F(EepromStore, AThesisRecordOverTheSettingsHostMovesTheSettingFirst) {
  // given: the divider stored in slot 3, a v2 model in slot 1
  tc::writeModelV2<Ee>(1, m1);
  ASSERT_EQ(tc::storeSettings<Ee>(divider(100000, 22000)).host, 3);
  // when: a thesis record goes into slot 3, cut anywhere
  tc::MotorCalibration cal = cal_a;
  const std::vector<uint8_t> before = Ee::image();
  Ee::restore(before);  // counts from here
  cal = cal_a;
  tc::storeRecordV1<Ee>(3, cal);
  const int32_t total = static_cast<int32_t>(Ee::update_calls);
  for (int32_t k = 0; k <= total; ++k) {
    Ee::restore(before);
    Ee::budget = k;
    cal = cal_a;
    tc::storeRecordV1<Ee>(3, cal);
    Ee::budget = -1;
    // then: the divider survives every cut
    tc::BoardSettings s;
    ASSERT_EQ(tc::readSettings<Ee>(s).status, tc::DecodeStatus::kOk) << k;
    EXPECT_TRUE(sameDivider(s, divider(100000, 22000))) << k;
  }
  tc::BoardSettings s;
  EXPECT_NE(tc::readSettings<Ee>(s).host, 3);
}

TEST_F(EepromStore, WithFourThesisRecordsThereIsNoRoomForTheDividerAndTheLastHostIsKept) {
  // given: slots 0..2 thesis records, the divider in slot 3 (the last host)
  for (uint8_t s = 0; s < 3; ++s) putV1(s, cal_b);
  ASSERT_EQ(tc::storeSettings<Ee>(divider(100000, 22000)).status, tc::SettingsWriteStatus::kWritten);
  // when: a thesis record would take slot 3
  tc::MotorCalibration cal = cal_a;
  const tc::StoreReport rep = tc::storeRecordV1<Ee>(3, cal);
  // then: refused, nothing changed
  EXPECT_EQ(rep.status, tc::StoreStatus::kSettingsNoRoom);
  tc::BoardSettings s;
  EXPECT_EQ(tc::readSettings<Ee>(s).host, 3);
  // with the default divider it may go (nothing is lost), and then nothing is left to host one
  ASSERT_EQ(tc::storeSettings<Ee>(tc::BoardSettings()).status, tc::SettingsWriteStatus::kWritten);
  cal = cal_a;
  EXPECT_EQ(tc::storeRecordV1<Ee>(3, cal).status, tc::StoreStatus::kStored);
  EXPECT_EQ(tc::storeSettings<Ee>(divider(100000, 22000)).status, tc::SettingsWriteStatus::kNoRoom);
  EXPECT_TRUE(tc::readSettings<Ee>(s).status != tc::DecodeStatus::kOk && s.isDefault());
}

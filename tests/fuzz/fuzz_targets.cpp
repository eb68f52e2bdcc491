// Fuzz targets (see fuzz_targets.hpp).
#include "fuzz_targets.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <stdexcept>

#include "lab/dataset.hpp"
#include "lab/model.hpp"
#include "hal/board.hpp"
#include "hex/intel_hex.hpp"
#include "test_records.hpp"
#include "thrustcal/board_settings.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/eeprom_store.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/plausibility.hpp"
#include "thrustcal/record_v2.hpp"

namespace fuzz {

void violation(const std::string& what) {
  std::fprintf(stderr, "fuzz: broken promise: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

namespace {

std::string text(const uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// ---- Intel HEX --------------------------------------------------------------------------------

std::vector<std::string> hexSeeds() {
  std::vector<uint8_t> image(4096, 0xFF);
  for (std::size_t i = 0; i < 300; ++i) image[i * 13 % 4096] = static_cast<uint8_t>(i);
  return {hex::formatIntelHex(image), ":0100100042AD\n:00000001FF\n",
          ":020000040000FA\r\n:0100000055AA\r\n:00000001FF\r\n", ":02000004FFFFFC\n:01FFFF0042BF\n:00000001FF\n",
          ":020000021000EC\n:0100000055AA\n:00000001FF\n"};
}

}  // namespace

void intelHex(const uint8_t* data, std::size_t size) {
  const std::string in = text(data, size);
  std::vector<uint8_t> image;
  try {
    image = hex::parseIntelHex(in, 4096, "fuzz.hex");
  } catch (const hex::HexError&) {
    return;  // refused with a message: fine
  }
  if (image.size() != hal::kEepromBytes) violation("image size " + std::to_string(image.size()));
  const std::vector<uint8_t> back = hex::parseIntelHex(hex::formatIntelHex(image), 4096, "roundtrip.hex");
  if (back != image) violation("an accepted image does not round-trip through formatIntelHex");
}

// ---- EEPROM decoders ---------------------------------------------------------------------------

namespace {

struct Image {
  static uint8_t* bytes;
  static uint8_t readByte(uint16_t addr) { return bytes[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) { bytes[addr] = value; }
};
uint8_t* Image::bytes = nullptr;

struct Loaded {
  tc::SlotLoad load;
  tc::ModelV2 v2;
  std::unique_ptr<tc::MotorCalibration> v1 = std::make_unique<tc::MotorCalibration>();
};

Loaded loadSlot(uint8_t slot, const tc::RecordLimits& limits) {
  Loaded l;
  l.load = tc::loadSlot<Image>(slot, l.v2, *l.v1, limits);
  return l;
}

// Whatever loads must be plausible and fly inside the ESC range.
void checkLoaded(const Loaded& l, uint8_t slot, const tc::RecordLimits& limits) {
  if (l.load.status != tc::DecodeStatus::kOk) {
    if (l.v2.isPresent() || l.v1->isCalibrated())
      violation(fmt::format("slot {}: not calibrated but a model is left loaded", slot));
    return;
  }
  const tc::ForcePwmLimits esc;
  const uint16_t buses[] = {0, 2999, 3000, 7400, 12600, 15638, 16800, 25200, 26000, 65535};
  if (l.load.layout == tc::SlotLayout::kModelV2) {
    if (!tc::checkModelV2(l.v2, limits).ok()) violation(fmt::format("slot {}: implausible v2 model loaded", slot));
    for (uint16_t bus_mv : buses) {
      tc::BusVoltageFilter bus;
      bus.reset(bus_mv);
      for (uint32_t f = 0; f <= 65535; f = f * 3 + 7) {
        const uint16_t force = static_cast<uint16_t>(f);
        const tc::ForcePwmResult r = tc::forceToPwmV2(l.v2, force, bus);
        const tc::ForcePwmResult s = tc::forceToPwmV2(l.v2, force, bus, static_cast<uint16_t>(f / 2));
        if (r.pwm_us < esc.pwm_min_us || r.pwm_us > esc.pwm_max_us || s.pwm_us < esc.pwm_min_us ||
            s.pwm_us > esc.pwm_max_us)
          violation(fmt::format("slot {}: v2 flies {} / {} us for {} dg at {} mV", slot, r.pwm_us, s.pwm_us, f, bus_mv));
        (void)tc::forceForPwmDg(l.v2, static_cast<uint16_t>(1000 + f % 1001), bus_mv);
      }
      (void)tc::headroomDg(l.v2, bus_mv);
    }
  } else {
    tc::MotorCalibration copy = *l.v1;
    if (!tc::checkCalibration(copy, limits).ok()) violation(fmt::format("slot {}: implausible v1 record loaded", slot));
    for (uint16_t bus_mv : buses) {
      for (uint16_t g = 0; g <= 5000; g = static_cast<uint16_t>(g * 2 + 1)) {
        const tc::ForcePwmResult r = tc::forceToPwm(*l.v1, g, bus_mv);
        if (r.pwm_us < esc.pwm_min_us || r.pwm_us > esc.pwm_max_us)
          violation(fmt::format("slot {}: v1 flies {} us for {} g at {} mV", slot, r.pwm_us, g, bus_mv));
      }
    }
  }
}

void putCrc(uint8_t* p, uint16_t covered) {
  const uint16_t crc = tc::crc16CcittFalse(p, covered);
  p[covered] = static_cast<uint8_t>(crc & 0xFF);
  p[covered + 1] = static_cast<uint8_t>(crc >> 8);
}

// Gives every structure in the image a right CRC (v1 records, v2 copies and spares, settings),
// so arbitrary content reaches the plausibility rules and the fixed-point maths.
void repairCrcs(uint8_t* image) {
  for (uint8_t s = 0; s < tc::kMotorSlots; ++s) {
    uint8_t* slot = image + tc::slotAddress(s);
    if (slot[0] == tc::kLayoutVersion1) {
      putCrc(slot, tc::kRecordCrcOffset);
      continue;
    }
    const uint16_t v2_at[] = {0, tc::kRecordV2CopyOffset, tc::kRecordV2SpareOffset, 2 * tc::kRecordV2SpareOffset,
                              3 * tc::kRecordV2SpareOffset};
    for (uint16_t at : v2_at)
      if (slot[at] == tc::kLayoutVersion2) putCrc(slot + at, static_cast<uint16_t>(tc::recordV2Length(slot[at + 5]) - 2));
    for (uint16_t at : tc::kSettingsOffset)
      if (slot[at] == tc::kSettingsKind || slot[at] == tc::kSettingsKindBench)
        putCrc(slot + at, static_cast<uint16_t>(tc::settingsLength(slot[at]) - 2));
  }
}

bool sameLoad(const Loaded& a, const Loaded& b) {
  if (a.load.status != b.load.status) return false;
  if (a.load.status != tc::DecodeStatus::kOk) return true;
  if (a.load.layout != b.load.layout) return false;
  return a.load.layout == tc::SlotLayout::kModelV2 ? tc_test::sameModel(a.v2, b.v2)
                                                   : tc_test::sameCalibration(*a.v1, *b.v1);
}

std::vector<std::string> eepromSeeds() {
  using tc_test::CutEeprom;
  std::vector<std::string> seeds;
  auto snapshot = [&] {
    seeds.emplace_back(reinterpret_cast<const char*>(CutEeprom::bytes), sizeof CutEeprom::bytes);
  };
  tc_test::SyntheticMotor motor;
  const tc::MotorCalibration cal = tc_test::thesisRecord(motor, 12.4, 10.9);
  const tc::ModelV2 m1 = tc_test::fittedModel(motor, 12.4);
  motor.exponent = 1.6;
  const tc::ModelV2 m2 = tc_test::fittedModel(motor, 11.1);
  CutEeprom::erase();
  snapshot();  // erased
  tc::MotorCalibration c = cal;
  tc::writeRecord<CutEeprom>(0, c);
  tc::writeModelV2<CutEeprom>(1, m1);
  tc::writeModelV2<CutEeprom>(1, m2);
  tc::storeSettings<CutEeprom>(tc::BoardSettings());
  snapshot();  // v1, v2 (both copies), settings
  tc::storeModelV2<CutEeprom>(0, m1);  // a v1 -> v2 switch through a spare
  c = cal;
  tc::storeRecordV1<CutEeprom>(2, c);
  snapshot();
  // a switch cut while its spare flies
  CutEeprom::erase();
  c = cal;
  tc::writeRecord<CutEeprom>(3, c);
  CutEeprom::budget = 200;
  tc::storeModelV2<CutEeprom>(3, m2);
  CutEeprom::budget = -1;
  snapshot();
  // the same images with the "repair CRCs" flag byte
  const std::size_t n = seeds.size();
  for (std::size_t i = 0; i < n; ++i) seeds.push_back(seeds[i] + '\x01');
  return seeds;
}

}  // namespace

// Input: up to 4096 bytes of EEPROM image (the rest erased), then an optional flag byte: odd
// means "give every structure a right CRC first".
void eepromImage(const uint8_t* data, std::size_t size) {
  std::vector<uint8_t> bytes(4096, 0xFF);
  std::memcpy(bytes.data(), data, size < bytes.size() ? size : bytes.size());
  if (size > bytes.size() && (data[bytes.size()] & 1)) repairCrcs(bytes.data());
  Image::bytes = bytes.data();
  tc::BoardSettings settings;
  tc::readSettings<Image>(settings);
  if (!settings.isValid()) violation("invalid divider loaded");
  const tc::RecordLimits limits = settings.recordLimits();
  Loaded before[tc::kMotorSlots];
  for (uint8_t s = 0; s < tc::kMotorSlots; ++s) {
    before[s] = loadSlot(s, limits);
    checkLoaded(before[s], s, limits);
  }
  // Recovery (the first step of every gather_store store) never changes what a slot flies.
  std::vector<uint8_t> recovered = bytes;
  Image::bytes = recovered.data();
  tc::recoverSlots<Image>(limits);
  for (uint8_t s = 0; s < tc::kMotorSlots; ++s) {
    if (!sameLoad(loadSlot(s, limits), before[s])) violation(fmt::format("recovery changed slot {}", s));
  }
  Image::bytes = nullptr;
}

// ---- lab: column maps, expressions, CSV ----------------------------------------------------------

namespace {

const char kCsv[] =
    "pwm_us,force_g,vbat_v,temp_c,weight[g],current_a\n"
    "1100,10,12.5,25,40,0.5\n1200,60,12.4,26,240,1.5\n1300,140,12.3,27,560,3\n"
    "1400,240,12.2,28,960,4.5\n1500,360,12.0,29,1440,6\n1600,480,11.9,30,1920,8\n";

std::vector<std::string> mapSeeds() {
  return {std::string("force_g=weight[g]/4\n") + kCsv, std::string("pwm_us=pwm_us*1+0\n") + kCsv,
          std::string("force_g=weight_g*-1\n") + kCsv, std::string("vbat_v=vbat_v/0\n") + kCsv};
}

std::vector<std::string> expressionSeeds() {
  return {"curve+mul: 1 + a*(temp_c - 25)", "curve+deadband+voltage+add: b*current_a",
          "curve+mul: exp(a*vbat_v)/(1+b)", "curve+add: c*sin(pwm_us)^2", "curve+mul: (((a"};
}

std::vector<std::string> csvSeeds() {
  return {kCsv,
          "# gather_store sweep\npwm_us,force_g,vbat_v,t_s,motor,dir\n1000,0.0,12.400,0.210,0,1\n"
          "1010,0.8,12.400,0.420,0,1\n",
          "Time (s),ESC signal (µs),Thrust (kgf),Voltage (V),Current (A),\n0.1,1000,0.000,16.8,0.1,\n"
          "0.2,1100,0.050,16.7,1.0,\n",
          "pwm_us,force_g\n1e300,nan\ninf,-inf\n"};
}

lab::Dataset smallDataset() {
  lab::ReadOptions options;
  return lab::parseText(kCsv, "fuzz.csv", options);
}

void checkDataset(const lab::Dataset& d) {
  if (d.names.size() != d.columns.size()) violation("names and columns disagree");
  for (const auto& c : d.columns)
    if (c.size() != d.rows()) violation("a column's length is not the row count");
  for (int r : d.run)
    if (r < 0 || static_cast<std::size_t>(r) >= d.runs()) violation("a row in a run that does not exist");
}

}  // namespace

void columnMap(const uint8_t* data, std::size_t size) {
  const std::string in = text(data, size);
  const std::size_t nl = in.find('\n');
  const std::string map_text = in.substr(0, nl);
  const std::string csv = nl == std::string::npos ? std::string(kCsv) : in.substr(nl + 1);
  lab::ReadOptions options;
  try {
    options.maps.push_back(lab::parseColumnMap(map_text));
  } catch (const std::invalid_argument&) {
    return;
  }
  try {
    checkDataset(lab::parseText(csv, "fuzz.csv", options));
  } catch (const std::exception&) {
    // refused with a message (the lab CLI prints what() of any std::exception)
  }
}

void labExpression(const uint8_t* data, std::size_t size) {
  static const lab::Dataset train = smallDataset();
  lab::ModelSpec spec;
  try {
    spec = lab::parseSpec(text(data, size));
  } catch (const std::invalid_argument&) {
    return;
  }
  try {
    lab::Model model(spec, train);
    if (size <= 64) {  // a fit per input keeps libFuzzer fast enough on short expressions
      const lab::FitResult r = model.fit();
      if (r.predicted_g.size() != train.rows()) violation("prediction of the wrong length");
    }
  } catch (const std::exception&) {
    // refused with a message (the lab CLI prints what() of any std::exception)
  }
}

void labCsv(const uint8_t* data, std::size_t size) {
  lab::ReadOptions options;
  options.split_by_motor = (size & 1) != 0;
  try {
    checkDataset(lab::parseText(text(data, size), "fuzz.csv", options));
  } catch (const std::exception&) {
    // refused with a message (the lab CLI prints what() of any std::exception)
  }
}

const std::vector<Target>& targets() {
  static const std::vector<Target> all = {
      {"intel_hex", intelHex, hexSeeds},         {"eeprom_image", eepromImage, eepromSeeds},
      {"column_map", columnMap, mapSeeds},       {"lab_expression", labExpression, expressionSeeds},
      {"lab_csv", labCsv, csvSeeds},
  };
  return all;
}

const Target* findTarget(const std::string& name) {
  for (const Target& t : targets())
    if (name == t.name) return &t;
  return nullptr;
}

}  // namespace fuzz

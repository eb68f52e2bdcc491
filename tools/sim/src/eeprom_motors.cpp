// Which motors an EEPROM image's records were made for (sim/eeprom_motors.hpp).
#include "sim/eeprom_motors.hpp"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace sim {

namespace {
constexpr const char* kFormat = "thrustcal eeprom motors 1";

std::string seedList(const std::array<SlotMotor, 4>& m) {
  return fmt::format("{}, {}, {}, {}", m[0].seed, m[1].seed, m[2].seed, m[3].seed);
}
}  // namespace

std::string eepromMotorsPath(const std::string& eeprom_path) { return eeprom_path + ".motors.json"; }

std::optional<EepromMotors> readEepromMotors(const std::string& eeprom_path) {
  const std::string path = eepromMotorsPath(eeprom_path);
  if (!std::filesystem::exists(path)) return std::nullopt;
  std::ifstream in(path);
  EepromMotors out;
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    if (j.value("format", "") != kFormat)
      throw std::runtime_error(fmt::format("\"format\" is not \"{}\"", kFormat));
    for (const nlohmann::json& s : j.at("slots")) {
      const int slot = s.at("slot").get<int>();
      if (slot < 0 || slot > 3) throw std::runtime_error(fmt::format("slot {} is not 0..3", slot));
      out.slots[slot] = SlotMotor{s.at("preset").get<std::string>(), s.at("seed").get<uint64_t>(),
                                  s.value("variation", 0.03)};
    }
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("{}: {}; delete it (it only says which motors the records were "
                                         "made for) or calibrate again with sim gather",
                                         path, e.what()));
  }
  return out;
}

void writeEepromMotors(const std::string& eeprom_path, const EepromMotors& motors) {
  nlohmann::json j;
  j["format"] = kFormat;
  j["slots"] = nlohmann::json::array();
  for (int i = 0; i < 4; ++i) {
    if (!motors.slots[i]) continue;
    const SlotMotor& m = *motors.slots[i];
    j["slots"].push_back({{"slot", i}, {"preset", m.preset}, {"seed", m.seed}, {"variation", m.variation}});
  }
  const std::string path = eepromMotorsPath(eeprom_path);
  std::ofstream out(path, std::ios::trunc);
  out << j.dump(2) << "\n";
  if (!out) throw std::runtime_error(fmt::format("{}: cannot write it; check the directory", path));
}

void recordGatheredMotors(const std::string& eeprom_path, const std::string& preset, double variation,
                          const std::vector<int>& slots, const std::vector<uint64_t>& seeds) {
  EepromMotors m;
  try {
    m = readEepromMotors(eeprom_path).value_or(EepromMotors());
  } catch (const std::runtime_error&) {
    m = EepromMotors();  // a broken sidecar is replaced: this gather knows its slots
  }
  for (std::size_t i = 0; i < slots.size() && i < seeds.size(); ++i)
    m.slots.at(slots[i]) = SlotMotor{preset, seeds[i], variation};
  writeEepromMotors(eeprom_path, m);
}

ConsoleMotors chooseConsoleMotors(const std::string& eeprom_path, const std::vector<uint64_t>& seeds,
                                  bool seeds_given, const std::string& preset, bool preset_given) {
  ConsoleMotors c;
  for (int i = 0; i < 4; ++i)
    c.motors[i] = SlotMotor{preset, i < static_cast<int>(seeds.size()) ? seeds[i] : static_cast<uint64_t>(i + 1), 0.03};
  const std::optional<EepromMotors> made = eeprom_path.empty() ? std::nullopt : readEepromMotors(eeprom_path);
  const std::string sidecar = eepromMotorsPath(eeprom_path);
  if (!made) {
    if (!eeprom_path.empty())
      c.notes.push_back(fmt::format("motors: seeds {} ({}); nothing says which motors the EEPROM's records "
                                    "were made for ({} missing): a slot may fly another motor than it "
                                    "was measured on",
                                    seedList(c.motors), preset, sidecar));
    return c;
  }
  std::string differ;
  for (int i = 0; i < 4; ++i) {
    if (!made->slots[i]) continue;
    const SlotMotor& rec = *made->slots[i];
    if (!seeds_given) c.motors[i].seed = rec.seed;
    if (!preset_given) c.motors[i].preset = rec.preset;
    const SlotMotor& fly = c.motors[i];
    if (fly.seed != rec.seed || fly.preset != rec.preset || std::fabs(fly.variation - rec.variation) > 1e-9)
      differ += fmt::format("{}slot {} flies seed {} {} ({:g} % variation) but its record was made for "
                            "seed {} {} ({:g} %)",
                            differ.empty() ? "" : "; ", i, fly.seed, fly.preset, 100 * fly.variation,
                            rec.seed, rec.preset, 100 * rec.variation);
  }
  if (differ.empty()) {
    c.notes.push_back(fmt::format("motors: seeds {} ({}), the motors the EEPROM's records were made for ({})",
                                  seedList(c.motors), c.motors[0].preset, sidecar));
  } else {
    c.notes.push_back(fmt::format("warning: {} ({}): the records and the motors differ, as after a "
                                  "motor swap without recalibrating; leave out --seeds/--preset to fly "
                                  "the recorded ones",
                                  differ, sidecar));
  }
  return c;
}

}  // namespace sim

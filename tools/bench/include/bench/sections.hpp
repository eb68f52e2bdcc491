// One benchmark = one section: its printed table(s) and its JSON object. `thrustcal bench all`
// prints every section and writes {"accuracy": ..., "compute": ..., ...} to --json.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/accuracy.hpp"
#include "bench/table.hpp"

namespace bench {

struct Section {
  std::string key;
  std::vector<Table> tables;
  nlohmann::json json;
};

// Paths the AVR-based sections need. Empty avr_build: <source>/build/avr.
struct AvrPaths {
  std::string avr_build;   // AVR build tree with firmware/{gather_store,read_run}/*.elf
  std::string probe_elf;   // the bench probe (built by tools/bench with avr-g++); "" = built-in
  std::string elf(const std::string& image) const;  // <avr_build>/firmware/<image>/<image>.elf
};

Section accuracySection(const AccuracyConfig& config);
Section computeSection(const AvrPaths& paths);
Section footprintSection(const AvrPaths& paths);
Section calibrationSection(const AvrPaths& paths, bool quick);
Section liftoffSection(const AvrPaths& paths, bool quick);

}  // namespace bench

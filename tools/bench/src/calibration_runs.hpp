// Benchmark 4's gather_store runs (sections_sim.cpp), shared with its fast-sweep rows
// (sections_fast_sweeps.cpp, issue 26 item 2). Internal to tools/bench; only with tools/sim.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/sections.hpp"
#include "sim/scenarios.hpp"
#include "thrustcal/model_v2.hpp"

namespace bench {

inline const std::vector<uint64_t> kSeeds = {11, 12, 13, 14};
inline const std::string kPreset = "kv1100_9x4.7";
constexpr double kVariation = 0.03;

struct CurveError {
  double max_pct = 0, rms_pct = 0;
  int worst_g = 0;  // gram of the largest error
  double max_flight_pct = 0;  // largest error over kFlightLoG..kBandHiG
  double rms_flight_pct = 0;  // RMS over kFlightLoG..kBandHiG (bench accuracy's band)
};

struct MethodRun {
  std::string key, name;
  int step_us = 10, settle_ms = 200;
  sim::GatherResult gather;
  bool settle_auto = false;           // settle_ms is the cap
  std::string store_v2;               // v2: how the model was stored
  std::vector<CurveError> errors;     // per motor, first sweep's bench
  std::vector<tc::ModelV2> v2;        // v2 only: decoded from the board's EEPROM
  std::vector<uint8_t> eeprom;        // what read_run flies
  std::vector<double> sweep_s;        // per motor, first sweep (simulated)
  double sweep_s_max = 0, sweep_s_mean = 0;
};

// gather_store in simavr on the motors of `seeds` (slots 0, 1, ...; benchmark 4: the four of
// kSeeds), a LiPo sweep then a 10 V one, starting from `eeprom` (empty: erased).
MethodRun gatherWith(const AvrPaths& paths, const std::string& key, const std::string& name, int step_us,
                     int settle_ms, sim::GatherModel model, bool settle_auto = false,
                     const std::vector<uint8_t>& eeprom = {}, const std::vector<uint64_t>& seeds = kSeeds);
// Decodes the v2 records gather_store wrote and checks each against its first sweep's bench.
void checkStoredV2(MethodRun& m);
// The run's figures: sweep time, curve error per motor and worst.
nlohmann::json methodJson(const MethodRun& m);
// Rows for 200 ms and 100 ms sweeps, as read and corrected with each slot's measured dynamics,
// beside `settle_auto` (sections_fast_sweeps.cpp): several minutes of simavr.
void addFastSweepRows(const AvrPaths& paths, const MethodRun& settle_auto, Table& t, nlohmann::json& json,
                      std::vector<TargetCheck>& targets);

}  // namespace bench

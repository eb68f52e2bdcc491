// The cheap figures against docs/results.json (bench/drift.hpp).
#include "bench/drift.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "bench/doc_blocks.hpp"

namespace bench {

namespace {

// The fixed figures: deterministic simulated cycles and bytes, so the tolerances only let through
// what does not change a figure the docs print (cycles 1 %, flash 0.5 %, a few bytes of SRAM).
const std::vector<DriftFigure>& fixedFigures() {
  static const std::vector<DriftFigure> figures = [] {
    std::vector<DriftFigure> f;
    for (const char* u : {"v2_read_run", "v2_frame", "thesis_controller", "thesis_battery_median",
                          "v2_battery_reading"})
      for (const char* k : {"mean_cycles", "max_cycles"})
        f.push_back({fmt::format("compute.updates.{}.{}", u, k), 2, 0.01, "cycles"});
    for (const char* image : {"gather_store", "read_run"}) {
      f.push_back({fmt::format("footprint.images.{}.flash_bytes", image), 0, 0.005, "B"});
      f.push_back({fmt::format("footprint.images.{}.sram_static_bytes", image), 16, 0, "B"});
      f.push_back({fmt::format("footprint.stack.{}.never_used_bytes", image), 32, 0, "B"});
    }
    for (const char* m : {"read_run_four_slots_bytes", "four_v1_bytes", "four_v2_bytes"})
      f.push_back({fmt::format("footprint.models_sram.{}", m), 0, 0, "B"});
    f.push_back({"fly.flash_bytes", 0, 0.005, "B"});
    f.push_back({"fly.sram_static_bytes", 16, 0, "B"});
    return f;
  }();
  return figures;
}

bool has(const nlohmann::json& j, const std::string& path) {
  try {
    return numbersAt(j, path).size() == 1;
  } catch (const std::exception&) {
    return false;
  }
}

std::string tolerance(const DriftFigure& f) {
  if (f.abs > 0 && f.rel > 0) return fmt::format("{:g} {} or {:g} %", f.abs, f.unit, 100 * f.rel);
  if (f.rel > 0) return fmt::format("{:g} %", 100 * f.rel);
  if (f.abs > 0) return fmt::format("{:g} {}", f.abs, f.unit);
  return "exact";
}

// Benchmarks 11 and 12 (docs/sim.md's TWI and DLPF tables): simulated cycles of air_probe's reads
// (the bus time exact, the drivers 1 % or 2 cycles, as compute) and the DLPF model's figures as
// the table prints them (delay 0.005 ms, -3 dB and noise 1 %).
void airframeFigures(const nlohmann::json& now, std::vector<DriftFigure>& out) {
  if (now.contains("twi") && now["twi"].contains("rows"))
    for (const auto& r : now["twi"]["rows"]) {
      const std::string row = fmt::format("twi.rows[scl_hz={},twps={},bytes={}]", r.at("scl_hz").dump(),
                                          r.at("twps").dump(), r.at("bytes").dump());
      out.push_back({row + ".bus_cycles_model", 0, 0, "cycles"});
      for (const char* k : {"polled_cycles", "interrupt_cycles"}) out.push_back({row + "." + k, 2, 0.01, "cycles"});
    }
  if (!now.contains("imu") || !now["imu"].contains("dlpf")) return;
  for (const auto& r : now["imu"]["dlpf"])
    for (const char* sensor : {"gyro", "accel"}) {
      const std::string at = fmt::format("imu.dlpf[cfg={}].{}", r.at("cfg").dump(), sensor);
      out.push_back({at + ".delay_ms", 0.005, 0, "ms"});
      out.push_back({at + ".noise_rms", 0, 0.01, sensor == std::string("gyro") ? "deg/s" : "mg"});
      if (r.at(sensor).contains("bandwidth_hz")) out.push_back({at + ".bandwidth_hz", 0, 0.01, "Hz"});
    }
}

}  // namespace

std::vector<DriftFigure> driftFigures(const nlohmann::json& now) {
  std::vector<DriftFigure> out;
  for (const DriftFigure& f : fixedFigures())
    if (has(now, f.path)) out.push_back(f);
  airframeFigures(now, out);
  if (!now.contains("swap") || !now["swap"].contains("runs")) return out;
  // The swap's figures are means over a 2.5 s window of a closed loop: a few digits of the
  // docs' tables, no more.
  const std::vector<DriftFigure> per_run = {{"rise_s", 0.002, 0.01, "s"},
                                            {"overshoot_pct", 0.5, 0, "pp"},
                                            {"settling_s", 0.05, 0, "s"},
                                            {"sse_deg", 0.05, 0, "deg"},
                                            {"itae", 0, 0.02, "deg s^2"},
                                            {"hover_pwm_spread_us", 1.0, 0, "us"}};
  for (const auto& r : now["swap"]["runs"]) {
    const std::string run = fmt::format("swap.runs[rig={},mode={},part={},gains={},axis={},seed={}]",
                                        r.at("rig").get<std::string>(), r.at("mode").get<std::string>(),
                                        r.at("part").get<std::string>(), r.at("gains").get<std::string>(),
                                        r.at("axis").get<std::string>(), r.at("seed").dump());
    for (const DriftFigure& f : per_run)
      if (r.contains(f.path) && r.at(f.path).is_number()) out.push_back({run + "." + f.path, f.abs, f.rel, f.unit});
  }
  return out;
}

DriftResult compareDrift(const nlohmann::json& docs, const nlohmann::json& now,
                         const std::vector<DriftFigure>& figures) {
  DriftResult r{Table("Drift: the cheap figures measured again against the docs' JSON",
                      {"figure", "docs' JSON", "now", "tolerance", "within?"}),
                0, 0, 0};
  for (const DriftFigure& f : figures) {
    const double v = numbersAt(now, f.path).at(0);
    ++r.compared;
    if (!has(docs, f.path)) {
      ++r.missing;
      r.table.addRow({f.path, "missing", fmt::format("{:g}", v), tolerance(f), "NO"});
      continue;
    }
    const double d = numbersAt(docs, f.path).at(0);
    const double allowed = std::max(f.abs, f.rel * std::fabs(d));
    const bool within = std::fabs(v - d) <= allowed + 1e-12 * std::fabs(d);
    r.drifted += !within;
    r.table.addRow({f.path, fmt::format("{:g}", d), fmt::format("{:g}", v), tolerance(f), verdict(within)});
  }
  return r;
}

}  // namespace bench

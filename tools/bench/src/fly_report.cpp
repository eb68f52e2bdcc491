// fly's bench section from its figures (bench/fly.hpp); the flights are sections_fly.cpp's.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "bench/fly.hpp"

namespace bench {

ReadToEdge matchReadsToEdges(const std::vector<uint64_t>& read_ends, const std::vector<uint64_t>& writes,
                             const std::vector<uint64_t>& rises, double cycles_per_us) {
  ReadToEdge r;
  std::size_t w = 0;
  for (std::size_t i = 0; i + 1 < read_ends.size(); ++i) {  // a frame whose read brought no pulses
    if (writes.empty() || read_ends[i] < writes.front()) continue;  // before the first: disarmed
    while (w < writes.size() && writes[w] <= read_ends[i]) ++w;
    if (w == writes.size() || writes[w] >= read_ends[i + 1]) ++r.without_pulses;
  }
  std::size_t next_read = 0, next_rise = 0;
  bool any = false;
  uint64_t last_read = 0;
  double sum_us = 0;
  for (const uint64_t write : writes) {
    while (next_read < read_ends.size() && read_ends[next_read] < write) ++next_read;
    if (next_read == 0) continue;  // written before any read in the window
    const uint64_t read = read_ends[next_read - 1];
    if (any && read == last_read) continue;  // a second write from the same read
    while (next_rise < rises.size() && rises[next_rise] <= write) ++next_rise;
    if (next_rise == rises.size()) break;  // its edge is after the window
    const double us = static_cast<double>(rises[next_rise] - read) / cycles_per_us;
    const double compute_us = static_cast<double>(write - read) / cycles_per_us;
    const double margin_us = static_cast<double>(rises[next_rise] - write) / cycles_per_us;
    r.min_us = any ? std::min(r.min_us, us) : us;
    r.max_us = std::max(r.max_us, us);
    r.compute_max_us = std::max(r.compute_max_us, compute_us);
    r.margin_min_us = any ? std::min(r.margin_min_us, margin_us) : margin_us;
    sum_us += us;
    ++r.frames;
    any = true;
    last_read = read;
  }
  r.mean_us = r.frames ? sum_us / static_cast<double>(r.frames) : 0.0;
  return r;
}

namespace {

bool cpuMet(const FlyModeFigures& m) {
  return m.stayed_armed && m.frames > 0 && m.cpu_load_pct <= kFlyCpuTargetPct;
}
bool edgeMet(const FlyModeFigures& m) {
  return m.stayed_armed && m.read_to_edge.frames > 0 && m.read_to_edge.max_us <= kFlyReadToEdgeTargetUs &&
         m.read_to_edge.without_pulses == 0;
}
bool stackMet(const FlyModeFigures& m) { return m.stack_never_used_bytes >= kStackTargetBytes; }
// status's worst computation (the firmware's own clock, from the read's end to the write) and the
// bench's (simulated cycles, the TWI's last byte to hal::Esc::writeAll) over the same flight.
constexpr double kStatusAgreesWithinUs = 10.0;
bool statusAgrees(const FlyModeFigures& m) {
  return m.status_compute_max_us >= 0 &&
         std::fabs(m.status_compute_max_us - m.read_to_edge.compute_max_us) <= kStatusAgreesWithinUs;
}

nlohmann::json modeJson(const FlyModeFigures& m) {
  const ReadToEdge& e = m.read_to_edge;
  return {
      {"name", m.name},
      {"stayed_armed", m.stayed_armed},
      {"window_s", m.window_s},
      {"frames", m.frames},
      {"cpu_load_pct", m.cpu_load_pct},
      {"cpu_load_stream_pct", m.cpu_load_stream_pct},
      {"loop_period_max_ms", m.loop_period_max_ms},
      {"frame_period_max_ms", m.frame_period_max_ms},
      {"read_to_edge_us", {{"frames", e.frames}, {"min", e.min_us}, {"mean", e.mean_us}, {"max", e.max_us}}},
      {"frames_without_pulses", e.without_pulses},
      {"compute_max_us", e.compute_max_us},
      {"status_compute_max_us", m.status_compute_max_us},
      {"edge_margin_min_us", e.margin_min_us},
      {"read_phase_us", m.read_phase_us},
      {"budget_us", m.budget_us},
      {"stack_never_used_bytes", m.stack_never_used_bytes},
      {"stack_bytes", m.stack_bytes},
      {"roll_before_step_deg", m.roll_before_step_deg},
      {"roll_after_step_deg", m.roll_after_step_deg},
      {"met",
       {{"cpu_load", cpuMet(m)}, {"read_to_edge", edgeMet(m)}, {"stack", stackMet(m)}, {"status_agrees", statusAgrees(m)}}}};
}

Table modesTable(const FlyImage& image, const std::vector<FlyModeFigures>& modes, Section& s) {
  Table t(
      "7. fly: the 400 Hz attitude loop on the virtual airframe, armed, hover then a 10 deg roll step "
      "(simavr cycles)",
      {"mode, records", "CPU load", "with stream", "read to edge mean..max", "computation max",
       "status says", "loop period max", "frame period max", "stack never used", "target", "met?"});
  for (const FlyModeFigures& m : modes) {
    const ReadToEdge& e = m.read_to_edge;
    const bool met = cpuMet(m) && edgeMet(m) && stackMet(m);
    t.addRow({m.name, fmt::format("{:.1f} %", m.cpu_load_pct), fmt::format("{:.1f} %", m.cpu_load_stream_pct),
              fmt::format("{:.0f}..{:.0f} us", e.mean_us, e.max_us),
              fmt::format("{:.0f} us", e.compute_max_us), fmt::format("{} us", m.status_compute_max_us),
              fmt::format("{:.2f} ms", m.loop_period_max_ms),
              fmt::format("{:.2f} ms", m.frame_period_max_ms), fmt::format("{} B", m.stack_never_used_bytes),
              "CPU <= 50 %, edge <= 1000 us, stack >= 512 B, status = bench",
              m.stayed_armed ? verdict(met && statusAgrees(m)) : "NO (disarmed)"});
    s.json["modes"][m.key] = modeJson(m);
  }
  const bool sram_met = image.size.sram_static_bytes <= kStaticSramTargetBytes;
  t.addRow({"flash (.text + .data) / static SRAM (.data + .bss)",
            fmt::format("{} / {} B", image.size.flash_bytes, image.size.sram_static_bytes), "", "", "", "", "",
            "", "", fmt::format("SRAM <= {} B", kStaticSramTargetBytes), verdict(sram_met)});
  s.json["met"]["sram_static"] = sram_met;
  t.addNote(
      fmt::format("airframe: {}; fly armed in the plus layout at 1200 g (pwm: at its hover pulse), "
                  "measured from `arm`: the 1 s spool-up, 1 s of hover, `sp 10 0` and 1.5 s more; `with stream`: "
                  "0.5 s more with `stream on`",
                  image.rig));
  t.addNote(
      "read to edge: from the TWI's last byte of an IMU read (status 0x58) to the rising edge of the ESC "
      "pulses that carry the result (the first compare-register write after the read, hal::Esc::writeAll, "
      "then the next rising edge); computation: read end to that write; status says: status's own "
      "worst computation over the same flight (the firmware's clock, read end to the write)");
  t.addNote(
      "CPU load: awake cycles / all cycles (simavr skips the idle sleep); loop period: between entries of "
      "FlyApp::runOnce, frame period: between entries of FlyApp::flyFrame (the armed computation)");
  t.addNote(
      "stack: the boot code paints the free SRAM; after the flight fly streamed rows, answered help under a "
      "flood and status, armed (sim/stack_scenario.hpp), and status says what was never touched");
  t.addNote(
      "records: four varied kv1100 9x4.7 motors calibrated on the host as gather_store stores them "
      "(bench/records.hpp); ardupilot flies one fit of all four");
  return t;
}

std::string partName(const std::string& part, std::size_t width) {
  return part.size() <= width ? part : part.substr(0, width - 3) + "...";
}

// Where the awake cycles of a frame go, by function: the parts that cost most in some mode.
Table breakdownTable(const std::vector<FlyModeFigures>& modes, Section& s) {
  std::vector<std::string> header = {"part"};
  std::map<std::string, double> worst;  // per frame, over the modes
  for (const FlyModeFigures& m : modes) {
    header.push_back(m.key);
    const double frames = m.frames ? static_cast<double>(m.frames) : 1.0;
    for (const auto& [part, cycles] : m.awake_cycles_by_part) {
      const double per_frame = static_cast<double>(cycles) / frames;
      worst[part] = std::max(worst[part], per_frame);
      s.json["breakdown"][m.key][part] = per_frame;
    }
  }
  std::vector<std::pair<double, std::string>> order;
  for (const auto& [part, cycles] : worst) order.push_back({-cycles, part});
  std::sort(order.begin(), order.end());
  constexpr std::size_t kRows = 16;
  Table t(
      "7b. fly: where a frame's awake cycles go, by function (cycles per frame, armed, mean over the window)",
      header);
  for (std::size_t i = 0; i < order.size() && i < kRows; ++i) {
    std::vector<std::string> row = {partName(order[i].second, 60)};
    for (const FlyModeFigures& m : modes) {
      const auto it = m.awake_cycles_by_part.find(order[i].second);
      const double frames = m.frames ? static_cast<double>(m.frames) : 1.0;
      row.push_back(it == m.awake_cycles_by_part.end() ? "-"
                                                       : fixed(static_cast<double>(it->second) / frames, 0));
    }
    t.addRow(row);
  }
  std::vector<std::string> total = {"all (a frame is 40000 cycles)"};
  for (const FlyModeFigures& m : modes) {
    uint64_t sum = 0;
    for (const auto& [part, cycles] : m.awake_cycles_by_part) sum += cycles;
    total.push_back(fixed(static_cast<double>(sum) / (m.frames ? static_cast<double>(m.frames) : 1.0), 0));
  }
  t.addRow(total);
  t.addNote(
      "each instruction's cycles counted at its address (interrupt entries at the instruction they "
      "interrupted), summed per function of the image's symbol table; avr-libc's float routines as one part; "
      "the largest parts only (every part is in the JSON)");
  return t;
}

void addTargets(const FlyImage& image, const std::vector<FlyModeFigures>& modes, Section& s) {
  double loop_max = 0;
  int stack_min = 1 << 30;
  for (const FlyModeFigures& m : modes) {
    s.targets.push_back({fmt::format("7. fly CPU load at 400 Hz, {}", m.name),
                         fmt::format("{:.1f} %", m.cpu_load_pct), "<= 50 %", cpuMet(m)});
    s.targets.push_back(
        {fmt::format("7. fly IMU read to the ESC edge, {}", m.name),
         fmt::format("max {:.0f} us (mean {:.0f})", m.read_to_edge.max_us, m.read_to_edge.mean_us),
         "<= 1000 us", edgeMet(m)});
    s.targets.push_back({fmt::format("7. fly status's worst computation = the bench's, {}", m.name),
                         fmt::format("{} us vs {:.0f} us", m.status_compute_max_us, m.read_to_edge.compute_max_us),
                         fmt::format("within {:.0f} us", kStatusAgreesWithinUs), statusAgrees(m)});
    s.json["met"][m.key] = {{"cpu_load", cpuMet(m)},
                            {"read_to_edge", edgeMet(m)},
                            {"stack", stackMet(m)},
                            {"status_agrees", statusAgrees(m)}};
    loop_max = std::max(loop_max, m.loop_period_max_ms);
    stack_min = std::min(stack_min, m.stack_never_used_bytes);
  }
  s.targets.push_back({"7. fly worst loop period (all modes)", fmt::format("{:.2f} ms", loop_max),
                       "measured by bench", true});
  s.targets.push_back({"7. fly stack never used (least over the modes)", fmt::format("{} bytes", stack_min),
                       ">= 512 bytes", stack_min >= kStackTargetBytes});
  s.targets.push_back({"7. static SRAM of fly (>= 2 KB left for the stack)",
                       fmt::format("{} bytes", image.size.sram_static_bytes),
                       fmt::format("<= {} bytes", kStaticSramTargetBytes),
                       image.size.sram_static_bytes <= kStaticSramTargetBytes});
  s.json["worst"] = {{"loop_period_max_ms", loop_max}, {"stack_never_used_bytes", stack_min}};
}

}  // namespace

Section flyReport(const FlyImage& image, const std::vector<FlyModeFigures>& modes) {
  Section s;
  s.key = "fly";
  s.json["available"] = true;
  s.json["elf"] = image.elf;
  s.json["rig"] = image.rig;
  s.json["frame_hz"] = 400;
  s.json["flash_bytes"] = image.size.flash_bytes;
  s.json["sram_static_bytes"] = image.size.sram_static_bytes;
  s.json["targets"] = {{"cpu_load_max_pct", kFlyCpuTargetPct},
                       {"read_to_edge_max_us", kFlyReadToEdgeTargetUs},
                       {"stack_never_used_min_bytes", kStackTargetBytes},
                       {"sram_static_max_bytes", kStaticSramTargetBytes}};
  s.tables.push_back(modesTable(image, modes, s));
  s.tables.push_back(breakdownTable(modes, s));
  addTargets(image, modes, s);
  return s;
}

}  // namespace bench

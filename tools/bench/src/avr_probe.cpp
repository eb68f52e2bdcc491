#include "bench/avr_probe.hpp"

#include <cstdio>
#include <memory>
#include <stdexcept>

#include "sim/cycle_probe.hpp"

namespace bench {

ProbeResult runProbe(const std::string& elf_path, uint64_t budget_cycles, int profile_label) {
  sim::CycleProbeRun run;
  try {
    run = sim::runCycleProbe(elf_path, budget_cycles, profile_label);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string(e.what()) +
                             " (the bench's AVR probe: rebuild the host tree, tools/bench builds it "
                             "with avr-g++)");
  }
  ProbeResult r;
  r.sections = run.sections;
  r.overhead_cycles = run.overhead_cycles;
  r.total_cycles = run.total_cycles;
  r.profile = run.profile;
  for (const auto& [key, b] : run.reported)
    if (b.size() >= 2) r.values[key] = static_cast<uint16_t>(b[0] | b[1] << 8);
  return r;
}

std::vector<std::pair<std::string, uint64_t>> cyclesByRange(const ProbeResult& r, const std::string& elf,
                                                            const std::vector<ProfileRange>& ranges,
                                                            const std::string& end_symbol) {
  // Symbol addresses from avr-nm (local labels of inline assembly included).
  std::unique_ptr<FILE, int (*)(FILE*)> p(popen(("avr-nm -S '" + elf + "' 2>/dev/null").c_str(), "r"), pclose);
  if (!p) throw std::runtime_error("cannot run avr-nm on " + elf + ": is binutils-avr installed?");
  std::map<std::string, uint32_t> address, size;
  char line[512];
  while (fgets(line, sizeof line, p.get())) {
    char name[400];
    unsigned addr = 0, bytes = 0;
    char type = 0;
    if (std::sscanf(line, "%x %x %c %399s", &addr, &bytes, &type, name) == 4) {
      address[name] = addr;
      size[name] = bytes;
    } else if (std::sscanf(line, "%x %c %399s", &addr, &type, name) == 3) {
      address[name] = addr;
    }
  }
  std::vector<uint32_t> starts;
  for (const ProfileRange& range : ranges) {
    if (!address.count(range.symbol))
      throw std::runtime_error("the AVR probe " + elf + " has no symbol " + range.symbol +
                               ": rebuild it (tools/bench builds it from core/)");
    starts.push_back(address.at(range.symbol));
  }
  if (!size.count(end_symbol)) throw std::runtime_error("the AVR probe has no function " + end_symbol);
  const uint32_t end = address.at(end_symbol) + size.at(end_symbol);
  std::vector<std::pair<std::string, uint64_t>> out;
  for (size_t i = 0; i < ranges.size(); ++i) {
    const uint32_t lo = starts[i], hi = i + 1 < ranges.size() ? starts[i + 1] : end;
    uint64_t sum = 0;
    for (auto it = r.profile.lower_bound(lo); it != r.profile.end() && it->first < hi; ++it) sum += it->second;
    out.emplace_back(ranges[i].name, sum);
  }
  return out;
}

std::string builtinProbePath() {
#ifdef THRUSTCAL_BENCH_PROBE_ELF
  return THRUSTCAL_BENCH_PROBE_ELF;
#else
  return {};
#endif
}

}  // namespace bench

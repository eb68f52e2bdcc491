#include "bench/cli.hpp"

#include <chrono>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include <fmt/format.h>

#include "bench/doc_blocks.hpp"
#include "bench/drift.hpp"
#include "bench/report.hpp"
#include "bench/sections.hpp"

namespace bench {

namespace {

struct Options {
  std::string json_path;
  AvrPaths paths;
  bool quick = false;
  int settle_ms = 0;  // 0: the benchmark's default
  int jobs = 1;       // swap: flights at once
};

SwapBenchOptions swapOptions(const Options& o) {
  SwapBenchOptions s;
  s.out_dir = sourcePath("build/bench/swap");
  s.jobs = o.jobs;
  s.quick = o.quick;
  return s;
}

void emit(const std::vector<Section>& sections, const Options& o) {
  nlohmann::json j;
  nlohmann::json tables = nlohmann::json::array();  // every printed table, in order
  for (const Section& s : sections) {
    for (const Table& t : s.tables) {
      t.print(std::cout);
      tables.push_back(t.toJson());
    }
    j[s.key] = s.json;
  }
  if (sections.size() > 1) {
    const Table targets = targetsTable(sections);
    targets.print(std::cout);
    tables.push_back(targets.toJson());
  }
  j["targets"] = targetsJson(sections);
  j["tables"] = tables;
  std::cout.flush();
  if (!o.json_path.empty()) {
    std::ofstream f(o.json_path);
    if (!f) throw std::runtime_error("cannot write " + o.json_path + ": check the directory exists");
    f << j.dump(2) << '\n';
    std::cout << "JSON written to " << o.json_path << '\n';
  }
}

AccuracyConfig accuracyConfig(const Options& o) {
  AccuracyConfig c;
  if (o.quick) {
    c.v_step = 0.3;
    c.force_step_g = 50;
  }
  if (o.settle_ms > 0) c.sweep.settle_ms = o.settle_ms;
  return c;
}

using Runner = std::function<std::vector<Section>(const Options&)>;

void add(CLI::App& bench, const std::shared_ptr<Options>& o, const std::string& name,
         const std::string& help, Runner run) {
  CLI::App* sub = bench.add_subcommand(name, help);
  sub->add_option("--json", o->json_path, "write the figures to this JSON file");
  sub->add_flag("--quick", o->quick, "coarser grids and shorter runs (for a smoke test)");
  sub->add_option("--avr-build", o->paths.avr_build,
                  "AVR build tree holding firmware/{gather_store,read_run}/*.elf "
                  "(default: <source>/build/avr)");
  if (name == "swap" || name == "all")
    sub->add_option("--jobs", o->jobs, "swap: flights at once, each its own simulated board (default 1)")
        ->check(CLI::Range(1, 64));
  if (name == "accuracy" || name == "all")
    sub->add_option("--settle-ms", o->settle_ms, "accuracy: settle time per sweep step (default 600)")
        ->check(CLI::Range(20, 5000));
  sub->callback([o, run] {
    try {
      emit(run(*o), *o);
    } catch (const std::exception& e) {
      std::cerr << "thrustcal bench: " << e.what() << '\n';
      throw CLI::RuntimeError(1);
    }
  });
}

std::string readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot read " + path + ": check the path");
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

// Writes `text` to `path`, or with `check` compares: true when the file already holds it.
bool writeOrCheck(const std::string& path, const std::string& text, bool check) {
  if (check) {
    if (readFile(path) == text) return true;
    std::cout << path << " differs from what the bench JSON gives: run tools/results.sh (or thrustcal bench "
                         "report without --check) and commit both\n";
    return false;
  }
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f || !(f << text)) throw std::runtime_error("cannot write " + path);
  std::cout << "written: " << path << '\n';
  return true;
}

struct ReportArgs {
  std::string from, results;
  std::vector<std::string> docs;
  bool check = false;
};

// Rewrites (or checks) the generated blocks of one markdown file; with --check, names the line
// of each block that differs.
bool blocksOf(const std::string& path, const nlohmann::json& bench, bool check) {
  const std::string text = readFile(path);
  const std::string want = withBlocks(text, path, bench);
  if (check && want != text) {
    for (const DocBlock& b : findBlocks(text, path)) {
      const std::string has = text.substr(b.content_begin, b.content_end - b.content_begin);
      if (has != renderBlock(b, bench))
        std::cout << fmt::format("{}:{}: the generated block \"{}\" differs from the JSON's figures\n", path,
                                 b.line, b.kind);
    }
  }
  return writeOrCheck(path, want, check);
}

void runReport(const ReportArgs& a) {
  const nlohmann::json bench = nlohmann::json::parse(readFile(a.from));
  bool same = true;
  if (!a.results.empty()) same = writeOrCheck(a.results, resultsMarkdown(bench), a.check) && same;
  int blocks = 0;
  for (const std::string& doc : a.docs) {
    if (doc == a.results) continue;  // written whole above
    blocks += static_cast<int>(findBlocks(readFile(doc), doc).size());
    same = blocksOf(doc, bench, a.check) && same;
  }
  if (!same) throw CLI::RuntimeError(1);
  if (a.check)
    std::cout << fmt::format("the docs hold the figures of {} ({} generated blocks in {} files)\n", a.from, blocks,
                             a.docs.size());
}

void addReport(CLI::App& bench) {
  CLI::App* sub = bench.add_subcommand(
      "report", "write docs/results.md and every generated block of the docs from `bench all --json` "
                "(tools/results.sh)");
  auto a = std::make_shared<ReportArgs>();
  sub->add_option("--from", a->from, "the JSON of `thrustcal bench all --json` (docs/results.json)")->required();
  sub->add_option("--results", a->results, "write the results page here (docs/results.md)");
  sub->add_option("--docs", a->docs,
                  "markdown files whose `<!-- generated: ... -->` blocks to rewrite (README.md docs/*.md)");
  sub->add_option("--readme", a->docs, "the same as --docs (README's measured table is such a block)");
  sub->add_flag("--check", a->check, "write nothing: fail when the files differ from what the JSON gives");
  sub->callback([a] {
    try {
      runReport(*a);
    } catch (const CLI::RuntimeError&) {
      throw;
    } catch (const std::exception& e) {
      std::cerr << "thrustcal bench report: " << e.what() << '\n';
      throw CLI::RuntimeError(1);
    }
  });
}

struct DriftArgs {
  std::string from, swap_dir;
  AvrPaths paths;
};

// A section's JSON, or an error when it could not be measured (a drift check that measured
// nothing must not pass).
nlohmann::json measured(const Section& s) {
  if (!s.json.value("available", true))
    throw std::runtime_error(fmt::format("{} could not be measured: {}", s.key, s.json.value("reason", "?")));
  return s.json;
}

void runDrift(const DriftArgs& a) {
  const nlohmann::json docs = nlohmann::json::parse(readFile(a.from));
  nlohmann::json now;
  now["compute"] = measured(computeSection(a.paths));
  now["footprint"] = measured(footprintSection(a.paths));
  const ImageSize fly = imageSize(a.paths.elf("fly"));
  now["fly"] = {{"flash_bytes", fly.flash_bytes}, {"sram_static_bytes", fly.sram_static_bytes}};
  now["twi"] = measured(twiSection());
  now["imu"] = measured(imuSection());
  SwapBenchOptions so;
  so.out_dir = a.swap_dir.empty() ? sourcePath("build/bench/swap-drift") : a.swap_dir;
  so.reduced = true;
  now["swap"] = measured(swapSection(a.paths, so));
  const DriftResult r = compareDrift(docs, now, driftFigures(now));
  r.table.print(std::cout);
  std::cout << fmt::format("compared {} figures with {}: {} drifted past their tolerance, {} missing there\n",
                           r.compared, a.from, r.drifted, r.missing);
  if (r.drifted + r.missing > 0) {
    std::cout << "the docs quote " << a.from << ", which no longer holds what the code measures: run "
              << "tools/results.sh and commit docs/results.json with the docs it rewrites\n";
    throw CLI::RuntimeError(1);
  }
}

void addDrift(CLI::App& bench) {
  CLI::App* sub = bench.add_subcommand(
      "drift", "measure the cheap figures again (compute cycles, image sizes, footprint, TWI and DLPF, a reduced swap) and "
               "fail when one moved past its tolerance from the docs' JSON");
  auto a = std::make_shared<DriftArgs>();
  sub->add_option("--from", a->from, "the JSON the docs are generated from (docs/results.json)")->required();
  sub->add_option("--avr-build", a->paths.avr_build, "AVR build tree (default: <source>/build/avr)");
  sub->add_option("--swap-dir", a->swap_dir,
                  "the reduced swap's calibration cache and series (default: <source>/build/bench/swap-drift)");
  sub->callback([a] {
    try {
      runDrift(*a);
    } catch (const CLI::RuntimeError&) {
      throw;
    } catch (const std::exception& e) {
      std::cerr << "thrustcal bench drift: " << e.what() << '\n';
      throw CLI::RuntimeError(1);
    }
  });
}

// `bench all`: every benchmark, in order.
std::vector<Section> allSections(const Options& o) {
  std::vector<Section> all;
  all.push_back(accuracySection(accuracyConfig(o)));
  all.push_back(computeSection(o.paths));
  all.push_back(footprintSection(o.paths));
  all.push_back(calibrationSection(o.paths, !o.quick));
  all.push_back(liftoffSection(o.paths, o.quick));
  all.push_back(runtimeSection(o.paths));
  all.push_back(safetySection(o.paths));
  all.push_back(flySection(o.paths));
  all.push_back(swapSection(o.paths, swapOptions(o)));
  all.push_back(speedSection(o.paths));
  all.push_back(dynamicsSection(o.paths, o.quick));
  all.push_back(rigsSection());
  all.push_back(twiSection());
  all.push_back(imuSection());
  return all;
}

}  // namespace

void registerCommands(CLI::App& app) {
  CLI::App* bench = app.add_subcommand(
      "bench", "Benchmarks: accuracy, AVR compute and footprint, calibration, lift-off, runtime, "
               "safety, fly, swap, speed, dynamics, rigs, twi, imu; each figure next to its target");
  bench->require_subcommand(1);
  auto o = std::make_shared<Options>();
  add(*bench, o, "accuracy",
      "force error of the uncalibrated map, thesis option 2.1, ArduPilot-style and v2 on four "
      "varied motors over 100-450 g and 9.9-12.6 V",
      [](const Options& o) { return std::vector<Section>{accuracySection(accuracyConfig(o))}; });
  add(*bench, o, "compute",
      "simulated ATmega2560 cycles for one four-motor update, thesis option 2.1 vs v2 (simavr)",
      [](const Options& o) { return std::vector<Section>{computeSection(o.paths)}; });
  add(*bench, o, "footprint",
      "flash and static SRAM of gather_store and read_run (avr-size), stack never used after the "
      "deepest paths (simavr), SRAM of the four models, "
      "EEPROM per motor",
      [](const Options& o) { return std::vector<Section>{footprintSection(o.paths)}; });
  add(*bench, o, "calibration",
      "simulated sweep time and stored-curve error of gather_store in simavr: thesis 200 ms steps "
      "vs a v2 sweep",
      [](const Options& o) { return std::vector<Section>{calibrationSection(o.paths, !o.quick)}; });
  add(*bench, o, "liftoff",
      "read_run in simavr on the tethered quad for a simulated minute on a draining pack: thesis "
      "vs v2 records",
      [](const Options& o) { return std::vector<Section>{liftoffSection(o.paths, o.quick)}; });
  add(*bench, o, "runtime",
      "read_run's CPU load, frame cycles and worst loop period in simavr at 50 and 400 Hz (lift-off "
      "on the tethered quad)",
      [](const Options& o) { return std::vector<Section>{runtimeSection(o.paths)}; });
  add(*bench, o, "safety",
      "issue 8 in simavr: time to stop every ESC pulse after a hang (watchdog), read_run's frame "
      "timing under UART floods",
      [](const Options& o) { return std::vector<Section>{safetySection(o.paths)}; });
  add(*bench, o, "fly",
      "fly, the 400 Hz attitude loop, on the virtual airframe in each mode: CPU load, loop period, IMU "
      "read to ESC edge, flash/SRAM, stack never used (simavr)",
      [](const Options& o) { return std::vector<Section>{flySection(o.paths)}; });
  add(*bench, o, "swap",
      "the swap experiment's full run (docs/fly.md): motor 1 exchanged, only its slot calibrated again, fly's "
      "10-degree steps in every mode on the seesaw and the gimbal (simavr; minutes)",
      [](const Options& o) { return std::vector<Section>{swapSection(o.paths, swapOptions(o))}; });
  add(*bench, o, "speed",
      "simulated seconds per wall second: read_run, fly on the gimbal, and a firmware with "
      "phase-correct PWM on INT4/INT5 (as MultiWii 2.4 on a Mega)",
      [](const Options& o) { return std::vector<Section>{speedSection(o.paths)}; });
  add(*bench, o, "dynamics",
      "each motor's spin-up and spin-down time constants as gather_store's dyn measures them in simavr, "
      "against the plant's own (stock motors and swap parts)",
      [](const Options& o) { return std::vector<Section>{dynamicsSection(o.paths, o.quick)}; });
  add(*bench, o, "rigs",
      "the seesaw's and the gimbal's physics against hand calculations: period, damping, end stop, "
      "torque steps, precession, yaw (plant only, seconds)",
      [](const Options&) { return std::vector<Section>{rigsSection()}; });
  add(*bench, o, "twi",
      "the test image air_probe reading the MPU-6050 in simavr at 400 and 100 kHz: the TWI's bus time against "
      "the datasheet's formula, the polled and the interrupt-driven driver's cycles (a second)",
      [](const Options&) { return std::vector<Section>{twiSection()}; });
  add(*bench, o, "imu",
      "the MPU-6050 model's DLPF settings measured on the chip model (delay, -3 dB, noise at rest) beside the "
      "datasheet's table (a second)",
      [](const Options&) { return std::vector<Section>{imuSection()}; });
  addReport(*bench);
  addDrift(*bench);
  add(*bench, o, "all", "every benchmark, in order, one JSON file", allSections);
}

}  // namespace bench

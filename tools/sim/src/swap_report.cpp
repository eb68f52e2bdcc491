// The swap experiment's table, targets, dynamics and plots (sim/swap_report.hpp).
#include "sim/swap_report.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace sim::swap {

namespace {

namespace fs = std::filesystem;


// One table row: a part's means over the IMU units (NaN when a run could not measure it).
struct Means {
  double rise_s = 0, overshoot_pct = 0, settling_s = 0, sse_deg = 0, itae = 0, integrator_mnm = 0,
         spread_us = 0;
  int runs = 0;
};

Means meansOf(const SwapResult& res, AirRig rig, const std::string& axis, Gains gains, Mode mode,
              const std::string& part) {
  Means m;
  for (const RunResult& r : res.runs) {
    const RunSpec& s = r.spec;
    if (s.rig != rig || s.axis != axis || s.gains != gains || s.mode != mode || s.part != part) continue;
    m.rise_s += r.metrics.rise_s, m.overshoot_pct += r.metrics.overshoot_pct,
        m.settling_s += r.metrics.settling_s;
    m.sse_deg += r.metrics.sse, m.itae += r.metrics.itae, m.integrator_mnm += r.integrator_mnm;
    m.spread_us += r.hover_pwm_spread_us, ++m.runs;
  }
  if (m.runs == 0) return m;
  for (double* v :
       {&m.rise_s, &m.overshoot_pct, &m.settling_s, &m.sse_deg, &m.itae, &m.integrator_mnm, &m.spread_us})
    *v /= m.runs;
  return m;
}

std::vector<std::string> axesOf(AirRig rig) {
  return rig == AirRig::kSeesaw ? std::vector<std::string>{"roll"}
                                : std::vector<std::string>{"roll", "pitch"};
}

std::vector<std::string> partsOf(const SwapOptions& o) {
  std::vector<std::string> parts = {kStock};
  parts.insert(parts.end(), o.parts.begin(), o.parts.end());
  return parts;
}

std::string fig(double v, int decimals) {
  return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : "-";
}

std::vector<std::string> tableRow(const Means& m, const Means* stock, const std::string& mode,
                                  const std::string& part) {
  auto vs = [&](double v, double s, const char* how) -> std::string {
    if (!stock || !std::isfinite(v) || !std::isfinite(s) || s == 0) return "";
    if (std::string(how) == "%") return fmt::format(" ({:+.1f} %)", 100.0 * (v / s - 1.0));
    if (std::string(how) == "pp") return fmt::format(" ({:+.1f} pp)", v - s);
    return fmt::format(" ({:.2f}x)", v / s);
  };
  return {mode,
          part,
          fig(m.rise_s, 3) + vs(m.rise_s, stock ? stock->rise_s : 0, "%"),
          fig(m.overshoot_pct, 1) + vs(m.overshoot_pct, stock ? stock->overshoot_pct : 0, "pp"),
          fig(m.settling_s, 2),
          fig(m.sse_deg, 2),
          fig(m.itae, 3) + vs(m.itae, stock ? stock->itae : 0, "x"),
          fig(m.integrator_mnm, 1),
          fig(m.spread_us, 1)};
}

// The console's columns: the widths of the cells above.
std::string alignedRow(const std::vector<std::string>& cells) {
  return fmt::format("{:<10} {:<14} {:<17} {:<17} {:<11} {:<8} {:<15} {:<11} {}\n", cells[0], cells[1], cells[2],
                     cells[3], cells[4], cells[5], cells[6], cells[7], cells[8]);
}

// The summary of one mode for the bar plot: a row per rig and axis, per part its means.
std::string barData(const SwapResult& res, Mode mode, const std::vector<std::string>& parts) {
  std::string t = "# rig_axis";
  for (const char* what : {"rise_s", "overshoot_pct", "itae", "spread_us"})
    for (const std::string& p : parts) t += fmt::format("\t{}:{}", what, p);
  t += "\n";
  for (AirRig rig : res.options.rigs)
    for (const std::string& axis : axesOf(rig)) {
      t += fmt::format("{}_{}", airRigName(rig), axis);
      std::vector<Means> m;
      for (const std::string& p : parts) m.push_back(meansOf(res, rig, axis, Gains::kPd, mode, p));
      for (int k = 0; k < 4; ++k)
        for (const Means& x : m) {
          const double v = k == 0 ? x.rise_s : k == 1 ? x.overshoot_pct : k == 2 ? x.itae : x.spread_us;
          t += "\t" + (std::isfinite(v) && x.runs ? fmt::format("{:.6g}", v) : std::string("NaN"));
        }
      t += "\n";
    }
  return t;
}

std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

void writeFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw std::runtime_error(fmt::format("{}: cannot write; check --out-dir", path.string()));
  out << text;
}

// The step responses of one mode (PD, the first IMU unit): a panel per rig and axis.
std::string stepsScript(const SwapResult& res, Mode mode, const fs::path& png,
                        const std::vector<std::string>& parts) {
  const SwapOptions& o = res.options;
  int panels = 0;
  for (AirRig rig : o.rigs) panels += static_cast<int>(axesOf(rig).size());
  std::string s = fmt::format("set terminal pngcairo size {},520 noenhanced font ',10'\nset output {}\n",
                              420 * panels, quote(png.string()));
  s += "set datafile separator ','\nset grid\nset key right bottom\n";
  s += fmt::format(
      "set multiplot layout 1,{} title {}\n", panels,
      quote(fmt::format("{}-degree steps, mode {}, PD gains, IMU unit {}: stock and each part in slot {} "
                        "(the rig's true angle)",
                        o.step_deg, modeName(mode), o.imu_seeds.front(), kSwapSlot)));
  for (AirRig rig : o.rigs)
    for (const std::string& axis : axesOf(rig)) {
      s += fmt::format("set title {}\nset xlabel 't from the step (s)'\nset ylabel '{} (deg)'\n",
                       quote(fmt::format("{} {}", airRigName(rig), axis)), axis);
      std::string plot = "plot ";
      for (const std::string& p : parts) {
        const RunSpec spec{rig, mode, p, Gains::kPd, axis, o.imu_seeds.front(), ""};
        const fs::path csv = fs::path(o.out_dir) / "series" / (runId(spec) + ".csv");
        plot += fmt::format("{} using 1:3 with lines lw 2 title {}, ", quote(csv.string()), quote(p));
        if (p == kStock)
          plot += fmt::format("{} using 1:2 with lines dt 2 lc rgb 'black' title 'setpoint', ",
                              quote(csv.string()));
      }
      s += plot.substr(0, plot.size() - 2) + "\n";
    }
  return s + "unset multiplot\nunset output\n";
}

// Rise, overshoot, ITAE and the hover pulse spread of one mode as clustered bars.
std::string barsScript(const SwapResult& res, Mode mode, const fs::path& tsv, const fs::path& png,
                       const std::vector<std::string>& parts) {
  std::string s = fmt::format("set terminal pngcairo size 1400,900 noenhanced font ',10'\nset output {}\n",
                              quote(png.string()));
  s += "set datafile separator '\\t'\nset style data histograms\nset style histogram clustered gap 1\n";
  s += "set style fill solid 0.8 border -1\nset grid ytics\nset key below horizontal\nset yrange [0:*]\n";
  s += "set offsets 0, 0, graph 0.08, 0\n";
  s += fmt::format(
      "set multiplot layout 2,2 title {}\n",
      quote(fmt::format("mode {}, PD gains: stock and each part in slot {}, means over {} IMU unit(s)",
                        modeName(mode), kSwapSlot, res.options.imu_seeds.size())));
  const char* titles[4] = {"rise time 10-90 % (s)", "overshoot (%)", "ITAE (deg s^2)",
                           "hover pulse spread (us)"};
  const std::size_t n = parts.size();
  for (std::size_t k = 0; k < 4; ++k) {
    s += fmt::format("set title {}\n", quote(titles[k]));
    std::string plot = "plot ";
    for (std::size_t p = 0; p < n; ++p)
      plot += fmt::format("{} using {}{} title {}, ", p == 0 ? quote(tsv.string()) : "''", 2 + k * n + p,
                          p == 0 ? ":xtic(1)" : "", quote(parts[p]));
    s += plot.substr(0, plot.size() - 2) + "\n";
  }
  return s + "unset multiplot\nunset output\n";
}

}  // namespace

std::vector<FigureTable> figureTables(const SwapResult& res) {
  const SwapOptions& o = res.options;
  std::vector<FigureTable> tables;
  for (AirRig rig : o.rigs)
    for (const std::string& axis : axesOf(rig))
      for (Gains gains : o.gains) {
        FigureTable t;
        t.rig = rig, t.axis = axis, t.gains = gains;
        const int ki = gains == Gains::kPid ? o.pid_ki : o.pd_gains[1];
        t.title = fmt::format("{} {}, {} gains ({} {} {} mN m), {}-degree step, mean of {} IMU unit(s)",
                              airRigName(rig), axis, gains == Gains::kPid ? "PID" : "PD", o.pd_gains[0], ki,
                              o.pd_gains[2], o.step_deg, o.imu_seeds.size());
        t.header = {"mode", "part", "rise s", "overshoot %", "settling s", "sse deg", "ITAE deg s^2",
                    "integrator mN m", "hover spread us"};
        for (Mode mode : o.modes) {
          const Means stock = meansOf(res, rig, axis, gains, mode, kStock);
          for (const std::string& p : partsOf(o))
            t.rows.push_back(
                tableRow(meansOf(res, rig, axis, gains, mode, p), p == kStock ? nullptr : &stock, modeName(mode), p));
        }
        if (!o.modes.empty()) tables.push_back(std::move(t));
      }
  // The peer's tables (the gimbal, its own gains), each part against its own stock runs.
  if (o.peer)
    for (const std::string& axis : axesOf(AirRig::kGimbal)) {
      FigureTable t;
      t.rig = AirRig::kGimbal, t.axis = axis, t.gains = Gains::kPd;
      t.title = fmt::format("gimbal {}, the peer {} with its own gains ({}), {}-degree step, mean of {} IMU unit(s)",
                            axis, o.peer->name, o.peer->file, o.step_deg, o.imu_seeds.size());
      t.header = {"mode", "part", "rise s", "overshoot %", "settling s", "sse deg", "ITAE deg s^2",
                  "integrator mN m", "hover spread us"};
      const Means stock = meansOf(res, AirRig::kGimbal, axis, Gains::kPd, Mode::kPeer, kStock);
      for (const std::string& p : partsOf(o))
        t.rows.push_back(tableRow(meansOf(res, AirRig::kGimbal, axis, Gains::kPd, Mode::kPeer, p),
                                  p == kStock ? nullptr : &stock, "peer:" + o.peer->name, p));
      tables.push_back(std::move(t));
    }
  return tables;
}

std::string formatTable(const SwapResult& res) {
  std::string out;
  for (const FigureTable& t : figureTables(res)) {
    out += fmt::format("\n{}; a part's change against stock in the same mode in brackets\n", t.title);
    out += alignedRow({"mode", "part", "rise_s", "overshoot_pct", "settling_s", "sse_deg", "itae_deg_s2",
                       "integ_mNm", "spread_us"});
    for (const auto& row : t.rows) out += alignedRow(row);
  }
  return out;
}

std::string formatTargets(const SwapResult& res) {
  if (res.targets.empty()) return "targets: none (they need force or force+dyn mode, PD gains and a swapped part)\n";
  std::string out = "targets (force and force+dyn modes, PD gains, each part against stock run by run; the worst run):\n";
  for (const Target& t : res.targets)
    out += fmt::format("  {:<4} {:<78} {:<48} {}\n", t.met ? "met" : "NOT", t.target, t.figure, t.wanted);
  return out;
}

std::string formatDynamics(const SwapResult& res) {
  const auto& st = res.dynamics.stock_tau_s;
  std::string out = fmt::format(
      "what static calibration cannot equalise: the motor's time constant (rpm, a +-10 % step "
      "around hover at 12.0 V); stock motors 0..3: {:.1f} {:.1f} {:.1f} {:.1f} ms\n",
      1e3 * st[0], 1e3 * st[1], 1e3 * st[2], 1e3 * st[3]);
  for (const Dynamics& d : res.dynamics.parts)
    out += fmt::format(
        "  {:<14} tau {:.1f} ms (stock motor {}: {:.1f} ms, {:+.1f} %); rise time in force mode, PD, "
        "roll: {} against stock\n",
        d.part, 1e3 * d.tau_s, kSwapSlot, 1e3 * d.stock_tau_s, 100.0 * (d.tau_s / d.stock_tau_s - 1.0),
        std::isfinite(d.rise_change_pct) ? fmt::format("{:+.1f} %", d.rise_change_pct)
                                         : std::string("not flown"));
  return out;
}

std::vector<std::string> writePlots(const SwapResult& res, const std::string& dir_name,
                                    std::vector<std::string>& warnings) {
  const fs::path dir(dir_name);
  fs::create_directories(dir);
  const std::vector<std::string> parts = partsOf(res.options);
  std::string script;
  std::vector<std::string> images;
  for (Mode mode : res.options.modes) {
    const fs::path tsv = dir / fmt::format("bars_{}.tsv", modeName(mode));
    writeFile(tsv, barData(res, mode, parts));
    const fs::path steps = dir / fmt::format("steps_{}.png", modeName(mode));
    const fs::path bars = dir / fmt::format("bars_{}.png", modeName(mode));
    script += "reset\n" + stepsScript(res, mode, steps, parts) + "reset\n" +
              barsScript(res, mode, tsv, bars, parts);
    images.push_back(steps.string());
    images.push_back(bars.string());
  }
  const fs::path gp = dir / "swap_plots.gp";
  writeFile(gp, script);
  const std::string log = (dir / "swap_plots.gnuplot.log").string();
  const int rc = std::system(("gnuplot " + quote(gp.string()) + " 2> " + quote(log)).c_str());
  if (rc == 0) return images;
  warnings.push_back(fmt::format("gnuplot failed (exit {}); see {}; the data and the script are in {}", rc,
                                 log, dir.string()));
  return {};
}

}  // namespace sim::swap

// `thesis`: the firmware's model (thesis option 2.1) as a base: built from the data as
// gather_store would, each row's force found through core's forceToPwm().
#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <stdexcept>

#include "lab/effect.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace lab::effects {
namespace {

class Thesis : public Term {
 public:
  explicit Thesis(Setup& s) : train_(s.train) {
    build();
    s.motor_ids = motors_;
  }
  bool hasOwnForce() const override { return true; }
  int countedParams() const override { return k_; }

  void ownForce(const Frame& f, const std::vector<double>& pw, Eigen::VectorXd& out) const override {
    const Rows& b = f.rows;
    out.resize(static_cast<Eigen::Index>(b.n));
    for (std::size_t i = 0; i < b.n; ++i) {
      const int mi = b.motor_index[i] < 0 ? 0 : b.motor_index[i];
      out[static_cast<Eigen::Index>(i)] = force(cals_[static_cast<std::size_t>(mi)], pw[i],
                                                b.vbat ? (*b.vbat)[i] : std::numeric_limits<double>::quiet_NaN());
    }
  }

  void warn(const Eigen::VectorXd& y, std::vector<std::string>& warnings) const override {
    std::size_t saturated = 0;
    double top = 0;
    for (const auto& cal : cals_) top = std::max<double>(top, std::max(cal.first.maxGrams(), cal.second.maxGrams()));
    for (Eigen::Index i = 0; i < y.size(); ++i)
      if (y[i] > top + 1) ++saturated;
    if (saturated)
      warnings.push_back(fmt::format("{} samples are above the thesis curves' heaviest gram ({:.0f} g): "
                                     "the model saturates there, as the firmware does", saturated, top));
  }

 private:
  const Dataset& train_;
  std::vector<long> motors_;
  std::vector<tc::MotorCalibration> cals_;
  int k_ = 0;  // the distinct PWMs in the curves

  // A run of one motor as gather_store saw it: its start voltage and its sag table.
  struct RunInfo {
    int run;
    uint16_t start_mv;
    tc::SagTable sag;
    bool sag_ok;
  };

  bool inRun(std::size_t i, int run, long motor, bool has_m) const {
    return train_.run[i] == run && (!has_m || std::lround(train_.col("motor")[i]) == motor);
  }

  RunInfo runInfo(int r, long m, bool has_v, bool has_m) const {
    const auto& pwm = train_.col("pwm_us");
    tc::SagBuilder sb;
    sb.reset(1000);
    double vsum = 0;
    std::size_t k = 0;
    for (std::size_t i = 0; i < train_.rows(); ++i) {
      if (!inRun(i, r, m, has_m)) continue;
      if (has_v) {
        const double mv = std::clamp(train_.col("vbat_v")[i] * 1000.0, 0.0, 65535.0);
        sb.add(static_cast<uint16_t>(std::clamp(pwm[i], 0.0, 65535.0)), static_cast<uint16_t>(mv));
        vsum += mv;
      }
      ++k;
    }
    RunInfo info{r, 0, tc::SagTable(), false};
    uint16_t start = 0;
    if (has_v && sb.build(info.sag, start)) {
      info.start_mv = start;
      info.sag_ok = true;
    } else if (has_v && k > 0) {
      info.start_mv = static_cast<uint16_t>(vsum / static_cast<double>(k));
    } else {
      info.start_mv = 12000;  // no voltage logged: a single curve, voltage term unused
    }
    return info;
  }

  // The run's curve through core's curve builder (forces merged per PWM); false when it
  // refuses.
  bool curve(const RunInfo& info, long m, bool has_m, tc::ThesisCurve& out) {
    const auto& pwm = train_.col("pwm_us");
    const auto& f = train_.col("force_g");
    std::map<long, std::pair<double, int>> merged;  // pwm -> force sum, count
    for (std::size_t i = 0; i < train_.rows(); ++i) {
      if (!inRun(i, info.run, m, has_m)) continue;
      auto& e = merged[std::lround(pwm[i])];
      e.first += f[i];
      e.second += 1;
    }
    auto cb = std::make_unique<tc::CurveBuilder<1024>>();
    std::size_t step = merged.size() / 1024 + 1, idx = 0;
    for (const auto& [p, e] : merged) {
      if (idx++ % step) continue;
      const double dg = std::clamp(10.0 * e.first / e.second, -32768.0, 32767.0);
      cb->add(static_cast<uint16_t>(std::clamp<long>(p, 0, 65535)), static_cast<int16_t>(std::lround(dg)));
    }
    const tc::BuildReport rep = cb->build(out);
    if (rep.status != tc::BuildStatus::kOk) return false;
    out.start_mv = info.start_mv ? info.start_mv : 1;
    k_ += rep.samples_used;
    return true;
  }

  // The second curve: the run whose start voltage differs most from the first (100 mV or more).
  static const RunInfo* secondRun(const std::vector<RunInfo>& infos) {
    const RunInfo* second = nullptr;
    for (const auto& info : infos)
      if (std::abs(int(info.start_mv) - int(infos[0].start_mv)) >= 100 &&
          (!second || std::abs(int(info.start_mv) - int(infos[0].start_mv)) >
                          std::abs(int(second->start_mv) - int(infos[0].start_mv))))
        second = &info;
    return second;
  }

  void build() {
    // per motor: runs with their start voltage
    const bool has_v = Setup::usable(train_, "vbat_v");
    const bool has_m = Setup::usable(train_, "motor");
    std::map<long, std::vector<int>> runs_of_motor;
    for (std::size_t i = 0; i < train_.rows(); ++i) {
      const long m = has_m ? std::lround(train_.col("motor")[i]) : 0;
      auto& v = runs_of_motor[m];
      if (std::find(v.begin(), v.end(), train_.run[i]) == v.end()) v.push_back(train_.run[i]);
    }
    for (auto& [m, runs] : runs_of_motor) {
      std::vector<RunInfo> infos;
      for (int r : runs) infos.push_back(runInfo(r, m, has_v, has_m));
      std::sort(infos.begin(), infos.end(),
                [](const RunInfo& a, const RunInfo& b) { return a.start_mv > b.start_mv; });
      tc::MotorCalibration cal;
      cal.clear();
      if (infos.empty() || !curve(infos[0], m, has_m, cal.first))
        throw std::invalid_argument(fmt::format(
            "thesis model: could not build a force curve for motor {} from its highest-voltage "
            "run (the core curve builder needs at least 2 PWMs and a force of 1 g or more)", m));
      cal.sag = infos[0].sag;
      if (!infos[0].sag_ok) cal.sag = tc::SagTable();
      if (infos.size() > 1)
        if (const RunInfo* second = secondRun(infos)) curve(*second, m, has_m, cal.second);
      motors_.push_back(m);
      cals_.push_back(cal);
    }
  }

  // Force the thesis model gives at this PWM and measured voltage (inverse of forceToPwm).
  static double force(const tc::MotorCalibration& cal, double pwm_us, double vbat_v) {
    const double mv_raw = std::isfinite(vbat_v) ? std::clamp(vbat_v * 1000.0, 0.0, 65535.0) : 0.0;
    tc::BatteryMonitor mon;
    const uint16_t mv = mv_raw > 0
                            ? mon.compensatedMillivolts(static_cast<uint16_t>(mv_raw),
                                                        static_cast<uint16_t>(std::clamp(pwm_us, 0.0, 65535.0)), cal.sag)
                            : static_cast<uint16_t>(mv_raw);
    const uint16_t gmax = std::max(cal.first.maxGrams(), cal.second.maxGrams());
    auto pwmAt = [&](uint16_t g) { return double(tc::forceToPwm(cal, g, mv).pwm_us); };
    if (gmax == 0) return 0;
    if (pwm_us <= pwmAt(0)) return 0;
    // largest g with pwm(g) <= pwm_us (pwm(g) is non-decreasing in g for sane voltages)
    uint16_t lo = 0, hi = gmax;
    if (pwmAt(hi) <= pwm_us) return gmax;
    while (hi - lo > 1) {
      const uint16_t mid = static_cast<uint16_t>((lo + hi) / 2);
      if (pwmAt(mid) <= pwm_us) lo = mid; else hi = mid;
    }
    const double p0 = pwmAt(lo), p1 = pwmAt(hi);
    return p1 > p0 ? lo + (pwm_us - p0) / (p1 - p0) : lo;
  }
};

}  // namespace

extern const EffectDef kThesis;
const EffectDef kThesis = {
    .name = "thesis",
    .role = Role::kBase,
    .physics = "The firmware's model (thesis option 2.1), built from the data as gather_store would: per "
               "motor, the run at the highest voltage is the first curve (with its start voltage and sag "
               "offsets), the run at the most different voltage the second; each row's force is the one "
               "for which core's forceToPwm() returns the row's PWM at the row's (sag-compensated) "
               "voltage. Replaces `curve`; parameters counted for the criteria: the distinct PWMs in the "
               "curves.",
    .columns = "pwm_us, force_g, vbat_v (for two curves)",
    .params = {},
    .export_note = "the thesis model is the v1 record, which gather_store writes on the board; export a "
                   "curve model, e.g. curve+deadband+voltage+sag",
    .suggests = {.variables = {"pwm_us", "vbat*", "voltage*", "v_v", "v"},
                 .still = "the thesis model is two measured curves interpolated linearly between their two voltages "
                          "(option 2.1): it cannot follow other voltages or shapes; compare with a curve model"},
    .make = [](Setup& s) -> std::unique_ptr<Term> { return std::make_unique<Thesis>(s); },
};

}  // namespace lab::effects

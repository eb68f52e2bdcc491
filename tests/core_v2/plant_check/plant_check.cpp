// Model v2 and thesis option 2.1 on the virtual bench's plant (tools/plant: ESC + BLDC +
// propeller with friction, IR drop and a thrust coefficient that rises with speed), steady
// state: four varied KV1100 + 9x4.7 actuators, sweeps recorded like gather_store records
// them (0.75 g load-cell steps, 15 mV monitor steps), then the force error over 100-450 g
// and 9.9-12.6 V. A preview of the bench's accuracy table; run by tests/core_v2/plant_check.sh.
#include <cmath>
#include <cstdio>

#include "plant/actuator.hpp"
#include "plant/params.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/model_v2.hpp"

namespace {

int16_t recordDg(double g) { return static_cast<int16_t>(std::lround(std::round(g / 0.75) * 0.75 * 10)); }
uint16_t recordMv(double v) { return static_cast<uint16_t>(std::lround(std::round(v * 1023 / 15.638) * 15638.0 / 1023)); }

struct Err {
  double sum_sq = 0, max = 0;
  int n = 0;
  void add(double e) { sum_sq += e * e; max = std::fmax(max, std::fabs(e)); ++n; }
  double rms() const { return n ? std::sqrt(sum_sq / n) : 0; }
};

struct Row {
  Err all, outside;
};

template <class PwmFor>
Row grid(const plant::Actuator& act, PwmFor pwm_for) {
  Row r;
  for (int vi = 0; vi <= 27; ++vi) {
    const double v = 9.9 + 0.1 * vi;
    for (double f = 100; f <= 450; f += 25) {
      const double truth = act.steadyState(pwm_for(f, static_cast<uint16_t>(std::lround(v * 1000))), v).thrust_g;
      const double e = 100 * (truth - f) / f;
      r.all.add(e);
      if (v < 10.5 - 1e-9 || v > 12.4 + 1e-9) r.outside.add(e);
    }
  }
  return r;
}

}  // namespace

int main() {
  tc::ForcePwmLimits limits;
  Row sum_thesis, sum_single, sum_refined;
  std::printf("motor  esc start | v2 one sweep: start, RMS/max %% | v2 refined: start, RMS/max %% | option 2.1: RMS/max %% (outside 10.5-12.4 V: RMS)\n");
  for (uint64_t seed = 0; seed < 4; ++seed) {
    const plant::ActuatorParams base = plant::presetParams("kv1100_9x4.7");
    const plant::ActuatorParams p = seed ? plant::makeVaried(base, seed, 0.03) : base;
    const plant::Actuator act(p);
    limits.pwm_max_us = static_cast<uint16_t>(p.esc.full_us);  // full throttle of this ESC
    static tc::ModelV2Fitter<128> fitter;
    static tc::CurveBuilder<128> builder;
    tc::MotorCalibration cal;
    auto sweep = [&](double v, tc::ThesisCurve& curve) {
      fitter.reset();
      builder.reset();
      for (int pwm = 1000; pwm <= 2000; pwm += 10) {
        const plant::OperatingPoint op = act.steadyState(pwm, v);
        fitter.add(static_cast<uint16_t>(pwm), recordDg(op.thrust_g), recordMv(op.bus_v));
        builder.add(static_cast<uint16_t>(pwm), recordDg(op.thrust_g));
      }
      builder.build(curve);
      curve.start_mv = recordMv(v);
    };
    tc::ModelV2 single, refined;
    sweep(12.4, cal.first);
    const tc::FitV2Status s1 = fitter.fit(single).status;
    refined = single;
    sweep(10.5, cal.second);
    const tc::FitV2Status s2 = fitter.refine(refined).status;
    if (s1 != tc::FitV2Status::kOk || s2 != tc::FitV2Status::kOk) {
      std::printf("motor %llu: fit failed: %s / %s\n", (unsigned long long)seed, tc::fitV2StatusText(s1),
                  tc::fitV2StatusText(s2));
      return 1;
    }
    auto v2 = [&](const tc::ModelV2& m) {
      return [&m, &limits](double f, uint16_t mv) {
        tc::BusVoltageFilter bus;
        bus.reset(mv);
        return static_cast<double>(tc::forceToPwmV2(m, static_cast<uint16_t>(f * 10), bus, limits).pwm_us);
      };
    };
    const Row a = grid(act, v2(single));
    const Row b = grid(act, v2(refined));
    const Row t = grid(act, [&](double f, uint16_t mv) {
      return static_cast<double>(tc::forceToPwm(cal, static_cast<uint16_t>(f), mv, limits).pwm_us);
    });
    std::printf("%5llu  %7.1f us | %7.2f us  %5.2f / %5.2f     | %7.2f us  %5.2f / %5.2f   | %5.2f / %5.2f  (%5.2f)\n",
                (unsigned long long)seed, p.esc.start_us, single.start_q4_us / 16.0, a.all.rms(),
                a.all.max, refined.start_q4_us / 16.0, b.all.rms(), b.all.max, t.all.rms(), t.all.max,
                t.outside.rms());
    auto merge = [](Row& into, const Row& r) {
      into.all.sum_sq += r.all.sum_sq; into.all.n += r.all.n; into.all.max = std::fmax(into.all.max, r.all.max);
      into.outside.sum_sq += r.outside.sum_sq; into.outside.n += r.outside.n;
      into.outside.max = std::fmax(into.outside.max, r.outside.max);
    };
    merge(sum_single, a);
    merge(sum_refined, b);
    merge(sum_thesis, t);
  }
  std::printf("all four motors, 100-450 g x 9.9-12.6 V (RMS / max %% of command; outside = beyond 10.5-12.4 V):\n");
  std::printf("  v2 one sweep at 12.4 V   %5.2f / %5.2f   outside %5.2f / %5.2f\n", sum_single.all.rms(), sum_single.all.max, sum_single.outside.rms(), sum_single.outside.max);
  std::printf("  v2 refined with 10.5 V   %5.2f / %5.2f   outside %5.2f / %5.2f\n", sum_refined.all.rms(), sum_refined.all.max, sum_refined.outside.rms(), sum_refined.outside.max);
  std::printf("  option 2.1 (12.4 + 10.5) %5.2f / %5.2f   outside %5.2f / %5.2f\n", sum_thesis.all.rms(), sum_thesis.all.max, sum_thesis.outside.rms(), sum_thesis.outside.max);
  return 0;
}

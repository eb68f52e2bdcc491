// The fit judged against the data's noise floor: the verdict (at the floor, suspects, or
// unexplained) in words with where to look, and the advice to follow next.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "lab/analysis.hpp"

namespace lab {

namespace {

// The advice to follow: rows that do not measure the force first, else the effect that explains
// most of the residual among the suspects' and the findings'.
Next nextAdvice(const std::vector<Suspect>& vars, const std::vector<Evidence>& ev) {
  Next next;
  for (const auto& e : ev)
    if (!e.where.empty()) return {e.where, "", e.cause, 0, {}};
  struct Option {
    bool significant;
    double score;
    std::string effect, why;
  };
  std::vector<Option> options;
  for (const auto& s : vars)
    if (s.tested && s.role == Role::kCause && !s.effects.empty())
      options.push_back({s.significant, s.score, s.effects.front(), s.advice});
  for (const auto& e : ev)
    if (!e.effects.empty()) options.push_back({e.significant, e.score, e.effects.front(), e.advice});
  std::stable_sort(options.begin(), options.end(), [](const Option& a, const Option& b) {
    return a.significant != b.significant ? a.significant : a.score > b.score;
  });
  for (const auto& o : options) {
    if (std::find(next.candidates.begin(), next.candidates.end(), o.effect) == next.candidates.end())
      next.candidates.push_back(o.effect);
    if (next.add.empty() && o.significant) next.add = o.effect, next.why = o.why, next.score = o.score;
  }
  return next;
}

// The verdict against the noise floor, in words with where to look.
void judge(Assessment& d, const Dataset& data, const FitResult& fit, const std::vector<Suspect>& variables) {
  const double rmse = fit.rmse_g;
  const NoiseEstimate& n = d.noise;
  d.unexplained_g = n.known() ? std::sqrt(std::max(0.0, rmse * rmse - n.sigma_g * n.sigma_g)) : rmse;
  const bool at_floor = atNoiseFloor(n, fit, &d.lack_of_fit);
  const LackOfFit& lof = d.lack_of_fit;
  if (lof.significant) d.unexplained_g = std::max(d.unexplained_g, lof.excess_g);
  bool explained = !d.next.where.empty();
  for (const auto& s : variables) explained = explained || (s.significant && s.role == Role::kCause);
  for (const auto& e : d.evidence) explained = explained || e.significant;
  if (at_floor) {
    d.verdict = Verdict::kAtNoiseFloor;
    d.verdict_text = fmt::format("at the noise floor: RMSE {:.3g} g is within the measurement noise, {}{}", rmse,
                                 describe(n), lof.tested ? "; " + lof.text : std::string());
    return;
  }
  std::string above = n.known() ? fmt::format("above the noise floor of {}", describe(n))
                                : "(the noise floor is " + describe(n) + ")";
  if (lof.significant && rmse <= n.hi_g)
    above = fmt::format("although the RMSE {:.3g} g is within the noise of {}: {}", rmse, describe(n), lof.text);
  d.regions = residualRegions(data, fit, n);
  if (explained) {
    d.verdict = Verdict::kSuspects;
    d.verdict_text = fmt::format("{:.3g} g unexplained {}; the suspects and findings above explain part of it",
                                 d.unexplained_g, above);
    return;
  }
  d.verdict = Verdict::kUnexplained;
  d.verdict_text = fmt::format("{:.3g} g unexplained {}: no logged variable explains it; look where it is, at a "
                               "condition not logged (a temperature, the voltage at the ESC, the rig's mount, the "
                               "load cell's tare), or at an effect not in the catalogue (`mul: EXPR`, `add: EXPR`)",
                               d.unexplained_g, above);
}

}  // namespace

bool atNoiseFloor(const NoiseEstimate& noise, const FitResult& fit, LackOfFit* lof_out) {
  const LackOfFit lof = lackOfFit(noise, fit.residual_g, fit.k);
  if (lof_out) *lof_out = lof;
  return noise.known() && fit.rmse_g <= noise.hi_g && !lof.significant;
}

const char* verdictName(Verdict v) {
  switch (v) {
    case Verdict::kAtNoiseFloor: return "at_noise_floor";
    case Verdict::kSuspects: return "suspects";
    case Verdict::kUnexplained: return "unexplained";
  }
  return "unexplained";
}

Assessment assess(const Dataset& data, const ModelSpec& spec, const FitResult& fit,
                  const std::vector<Suspect>& variables, const NoiseEstimate* noise) {
  Assessment a;
  a.noise = noise ? *noise : estimateNoise(data);
  std::size_t tested = 0;
  for (const auto& s : variables) tested += s.tested ? 1 : 0;
  a.evidence = gatherEvidence(data);
  scoreEvidence(data, fit, spec, a.evidence, tested);
  a.next = nextAdvice(variables, a.evidence);
  a.dynamics = dynamicsOf(fit);
  judge(a, data, fit, variables);
  return a;
}

}  // namespace lab

// Following the diagnosis's advice to the end (analysis.hpp, walk): the main job's lab step and
// `thrustcal lab walk`.
#include <fmt/format.h>

#include <algorithm>

#include "lab/analysis.hpp"

namespace lab {

namespace {

// Drops the rows the advice says do not measure the force; false when it was applied before (a
// finding that does not go away with its rows: stop rather than loop).
bool dropRows(Walk& w, WalkStep& step, const std::string& where) {
  if (w.where.find(where) != std::string::npos) {
    step.outcome = fmt::format("the rows outside '{}' were dropped already: stop", where);
    return false;
  }
  const std::size_t before = w.data.rows();
  const RowSelection sel = selectRows(w.data, where);
  w.where = w.where.empty() ? where : "(" + w.where + ") and " + where;
  step.outcome = fmt::format("dropped {} of {} rows (--where '{}'): {}", sel.dropped, before, where, step.advice.why);
  return true;
}

// The advised effect, else the other effects the diagnosis names in its order, each added to the
// model by the ladder: the first that earns its parameters (its `earns` false when none does).
LadderStep firstThatEarns(const Dataset& data, const ModelSpec& spec, const Diagnosis& d, WalkStep& step) {
  LadderStep prev;
  prev.spec = spec;
  prev.fit = d.fit;
  std::vector<std::string> order = d.next.candidates;
  if (!d.next.add.empty()) order.insert(order.begin(), d.next.add);
  std::vector<std::string> tried;
  LadderStep none;
  none.earns = false;
  for (const auto& add : order) {
    if (std::find(tried.begin(), tried.end(), add) != tried.end()) continue;
    tried.push_back(add);
    LadderStep next = addStep(data, prev, add, Holdout::kNone);
    const std::string outcome =
        fmt::format("+{}: RMSE {:.3g} g, dBIC {:.1f}, {}", add, next.fit.rmse_g, next.delta_bic, next.verdict);
    step.outcome += (step.outcome.empty() ? "" : "; ") + outcome;
    if (next.earns) return next;
  }
  return none;
}

}  // namespace

Walk walk(const Dataset& data, const ModelSpec& start, int max_adds, Holdout holdout) {
  Walk w;
  w.data = data;
  ModelSpec spec = start;
  for (int round = 0; round < 2 * max_adds + 4; ++round) {
    const Diagnosis d = diagnose(w.data, spec, Holdout::kNone);
    WalkStep step{spec.text(), w.data.rows(), d.fit.rmse_g, d.noise, d.verdict, d.verdict_text, d.next, ""};
    if (d.verdict == Verdict::kAtNoiseFloor) {
      step.outcome = "at the noise floor: done";
      w.stop = d.verdict_text;
      w.steps.push_back(step);
      break;
    }
    if (!d.next.where.empty()) {
      const bool dropped = dropRows(w, step, d.next.where);
      w.steps.push_back(step);
      if (!dropped) {
        w.stop = step.outcome;
        break;
      }
      continue;
    }
    if (d.next.candidates.empty() || static_cast<int>(w.adds.size()) >= max_adds) {
      step.outcome = d.next.candidates.empty() ? "nothing to add: stop" : fmt::format("{} effects added: stop", max_adds);
      w.stop = d.verdict_text;
      w.steps.push_back(step);
      break;
    }
    const LadderStep next = firstThatEarns(w.data, spec, d, step);
    w.steps.push_back(step);
    if (!next.earns) {
      w.stop = "nothing the diagnosis names earns its parameters: " + d.verdict_text;
      break;
    }
    spec = next.spec;
    w.adds.push_back(next.added);
  }
  w.ladder = ladder(w.data, start, w.adds, holdout);
  return w;
}

}  // namespace lab

// The diagnosis's probe (not a catalogue effect): a generic factor in one column that asks "how
// much would an effect in this variable help?": 1 + a*u + b*u^2 (u the standardised column), or a
// gain per level for a categorical column.
#include <fmt/format.h>

#include <algorithm>
#include <set>
#include <stdexcept>

#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class ProbeTerm : public Term {
 public:
  ProbeTerm(Setup& s, const Probe& pr) : column_(pr.column), categorical_(pr.categorical) {
    if (!s.train.has(pr.column)) throw std::invalid_argument("probe: no column " + pr.column);
    const auto& z = s.train.col(pr.column);
    if (pr.categorical) {
      std::set<double> lv;
      for (double v : z)
        if (std::isfinite(v)) lv.insert(v);
      levels_.assign(lv.begin(), lv.end());
      for (std::size_t k = 1; k < levels_.size(); ++k) {
        const int idx = s.add({fmt::format("gain_{}_{:g}", pr.column, levels_[k]), "1", "probe", 0.0, 0.02, -0.9, 10.0, 0.0});
        if (k == 1) first_ = idx;
      }
    } else {
      double sum = 0, s2 = 0;
      std::size_t n = 0;
      for (double v : z)
        if (std::isfinite(v)) { sum += v; s2 += v * v; ++n; }
      mean_ = n ? sum / static_cast<double>(n) : 0;
      sd_ = n ? std::sqrt(std::max(s2 / static_cast<double>(n) - mean_ * mean_, 0.0)) : 1;
      if (!(sd_ > 0)) sd_ = 1;
      first_ = s.add({fmt::format("{}_lin", pr.column), "1/sd", "probe", 0.0, 0.01, -kUnbounded, kUnbounded, 0.0});
      s.add({fmt::format("{}_quad", pr.column), "1/sd^2", "probe", 0.0, 0.01, -kUnbounded, kUnbounded, 0.0});
    }
  }
  void check(const Dataset& d) const override { (void)d.col(column_); }
  void factors(const Frame& f, const std::vector<double>&, Eigen::VectorXd& mul, Eigen::VectorXd&) const override {
    const auto& z = f.rows.data->col(column_);
    for (std::size_t i = 0; i < f.rows.n; ++i) {
      const auto r = static_cast<Eigen::Index>(i);
      if (first_ < 0 || !std::isfinite(z[i])) continue;
      if (categorical_) {
        const auto it = std::find(levels_.begin(), levels_.end(), z[i]);
        const long li = it - levels_.begin();
        if (it != levels_.end() && li > 0) mul[r] *= 1.0 + f.p(first_ + static_cast<int>(li) - 1);
      } else {
        const double u = (z[i] - mean_) / sd_;
        mul[r] *= 1.0 + f.th[first_] * u + f.th[first_ + 1] * u * u;
      }
    }
  }

 private:
  std::string column_;
  bool categorical_;
  double mean_ = 0, sd_ = 1;
  std::vector<double> levels_;
  int first_ = -1;
};

const EffectDef kProbe = {.name = "probe"};

}  // namespace

std::unique_ptr<Term> makeProbe(Setup& s, const Probe& probe) { return std::make_unique<ProbeTerm>(s, probe); }
const EffectDef& probeDef() { return kProbe; }

}  // namespace lab::effects

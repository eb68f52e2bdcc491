// `mul: EXPR` and `add: EXPR`: user effects written as muParser expressions; identifiers that are
// columns take the row's value, the others are fitted.
#include <fmt/format.h>
#include <muParser.h>

#include <stdexcept>

#include "lab/effect.hpp"

namespace lab::effects {
namespace {

class Expression : public Term {
 public:
  Expression(Setup& s, const UserEffect& u) : mul_(u.multiplicative), text_(u.expression) {
    parser_.SetVarFactory(
        [](const char*, void* self) -> double* {
          auto& storage = static_cast<Expression*>(self)->storage_;
          storage.push_back(std::make_unique<double>(0.0));
          return storage.back().get();
        },
        this);
    try {
      parser_.SetExpr(u.expression);
      for (const auto& v : parser_.GetUsedVar()) {
        if (s.train.has(v.first)) {
          if (v.first == "force_g") throw std::invalid_argument("an effect cannot use the measured force_g");
          columns_.emplace_back(v.first, v.second);
        } else {
          FitParam p = s.param(0);
          p.name = v.first;
          p.effect = s.def.prefix + " " + u.expression;
          params_.emplace_back(s.add(p), v.second);
        }
      }
      parser_.Eval();
    } catch (mu::Parser::exception_type& e) {
      throw std::invalid_argument(fmt::format("expression '{}': {} at position {}; write it in "
                                              "muParser syntax, e.g. 1 + a*(temp_c - 25)",
                                              u.expression, e.GetMsg(), e.GetPos() + 1));
    }
    if (params_.empty())
      throw std::invalid_argument(fmt::format(
          "expression '{}' has no free parameter to fit (every identifier is a column: {}); "
          "add one, e.g. 1 + a*(...)",
          u.expression, fmt::join(s.train.names, ", ")));
  }
  Expression(const Expression&) = delete;
  Expression& operator=(const Expression&) = delete;

  void check(const Dataset& d) const override {
    for (const auto& c : columns_)
      if (!d.has(c.first)) throw std::invalid_argument("expression '" + text_ + "' needs column " + c.first);
  }

  void factors(const Frame& f, const std::vector<double>&, Eigen::VectorXd& mul, Eigen::VectorXd& add) const override {
    for (const auto& pr : params_) *pr.second = f.th[pr.first];
    std::vector<const std::vector<double>*> cols;
    for (const auto& c : columns_) cols.push_back(&f.rows.data->col(c.first));
    for (std::size_t i = 0; i < f.rows.n; ++i) {
      for (std::size_t c = 0; c < columns_.size(); ++c) *columns_[c].second = (*cols[c])[i];
      double v;
      try {
        v = parser_.Eval();
      } catch (mu::Parser::exception_type&) {
        v = std::numeric_limits<double>::quiet_NaN();
      }
      if (mul_) mul[static_cast<Eigen::Index>(i)] *= v; else add[static_cast<Eigen::Index>(i)] += v;
    }
  }

 private:
  bool mul_;
  std::string text_;
  mu::Parser parser_;
  std::vector<std::unique_ptr<double>> storage_;
  std::vector<std::pair<std::string, double*>> columns_;  // column name -> slot
  std::vector<std::pair<int, double*>> params_;           // param index -> slot
};

}  // namespace

std::unique_ptr<Term> makeExpression(Setup& s, const UserEffect& u) { return std::make_unique<Expression>(s, u); }

extern const EffectDef kMul, kAdd;
const EffectDef kMul = {
    .name = "mul: EXPR",
    .role = Role::kExpression,
    .physics = "User effect: the force is multiplied by EXPR (muParser syntax). Identifiers that are "
               "columns take the row's value; any other identifier that is not a function or constant is "
               "a free parameter, fitted, starting at 0; write EXPR so that 0 means no effect (1 + a*..., "
               "not a*...), then a ladder step adding it never fits worse. Example: mul: 1 + a*(temp_c - 25).",
    .columns = "the columns EXPR names",
    .params = {{.name = "each free identifier", .unit = "1/unit", .meaning = "per unit of what it multiplies"}},
    .export_note = "the firmware evaluates no expressions (the record holds a curve, a start threshold and a "
                   "sag table); fit without it",
    .prefix = "mul:",
    .multiplicative = true,
};
const EffectDef kAdd = {
    .name = "add: EXPR",
    .role = Role::kExpression,
    .physics = "User effect: EXPR grams are added to the force. Same rules as mul:. Example: "
               "add: b*sin(t_s/60).",
    .columns = "the columns EXPR names",
    .params = {{.name = "each free identifier", .unit = "g/unit", .meaning = "grams per unit of what it multiplies"}},
    .export_note = kMul.export_note,
    .prefix = "add:",
};

}  // namespace lab::effects

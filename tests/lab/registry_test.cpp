// The effect registry is complete and consistent: every effect has a name, documentation and
// parameters with ranges; names are unique; the catalogue, `lab effects` and docs/lab.md list
// exactly the registry (`lab effects`: cli_test.cpp); a fit's parameters are the ones the registry documents, in its ranges;
// what suggests an effect and the advice the diagnosis gives are the registry's, and the diagnosis's sources name no effect.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "lab/analysis.hpp"
#include "lab/effect.hpp"
#include "lab/generate.hpp"
#include "lab/model.hpp"

namespace {

using lab::effects::EffectDef;
using lab::effects::Role;

bool documents(const EffectDef& e, const std::string& param) {
  for (const auto& p : e.params) {
    if (p.name == param) return true;
    // "gain_motor_N" documents gain_motor_2, gain_motor_17, ...
    if (p.name.size() > 1 && p.name.back() == 'N' && param.rfind(p.name.substr(0, p.name.size() - 1), 0) == 0)
      return true;
  }
  return false;
}

TEST(LabRegistry, EveryEffectHasANameDocumentationAndParametersWithRanges) {
  std::set<std::string> names, params;
  int bases = 0;
  for (const EffectDef* e : lab::effects::registry()) {
    ASSERT_NE(e, nullptr);
    EXPECT_FALSE(e->name.empty());
    EXPECT_TRUE(names.insert(e->name).second) << "two effects named " << e->name;
    EXPECT_GT(e->physics.size(), 40u) << e->name;
    EXPECT_FALSE(e->columns.empty()) << e->name;
    bases += e->role == Role::kBase;
    if (e->role == Role::kExpression) {
      EXPECT_FALSE(e->prefix.empty()) << e->name;
      EXPECT_EQ(e->make, nullptr) << e->name << ": expressions are made from the SPEC's text";
    } else {
      EXPECT_NE(e->make, nullptr) << e->name << " has no term (no formula)";
    }
    if (e->role == Role::kEffect) EXPECT_FALSE(e->params.empty()) << e->name << " fits nothing";
    if (e->exports != lab::effects::Export::kInRecord)
      EXPECT_FALSE(e->export_note.empty()) << e->name << ": say why a record cannot hold it";
    if (!e->needs.empty()) {
      EXPECT_NE(lab::effects::find(e->needs), nullptr) << e->name << " needs an unknown effect " << e->needs;
      EXPECT_FALSE(e->needs_why.empty()) << e->name;
    }
    for (const auto& p : e->params) {
      EXPECT_FALSE(p.name.empty()) << e->name;
      EXPECT_FALSE(p.unit.empty()) << e->name << " " << p.name;
      EXPECT_FALSE(p.meaning.empty()) << e->name << " " << p.name;
      if (e->role != Role::kExpression)
        EXPECT_TRUE(params.insert(p.name).second) << p.name << " is documented by two effects";
      EXPECT_LT(p.lo, p.hi) << e->name << " " << p.name;
      EXPECT_GT(p.scale, 0) << e->name << " " << p.name;
      if (p.from_data.empty()) {
        EXPECT_GE(p.init, p.lo) << e->name << " " << p.name;
        EXPECT_LE(p.init, p.hi) << e->name << " " << p.name;
        EXPECT_GE(p.neutral, p.lo) << e->name << " " << p.name;
        EXPECT_LE(p.neutral, p.hi) << e->name << " " << p.name;
      }
    }
  }
  EXPECT_GE(bases, 1);
  EXPECT_EQ(lab::effects::registry().front()->role, Role::kBase) << "the first base is the default";
}

TEST(LabRegistry, TheCatalogueIsTheRegistry) {
  const auto& cat = lab::effectCatalogue();
  const auto& reg = lab::effects::registry();
  ASSERT_EQ(cat.size(), reg.size());
  for (std::size_t i = 0; i < reg.size(); ++i) {
    EXPECT_EQ(cat[i].name, reg[i]->name);
    EXPECT_EQ(cat[i].parameters, lab::effects::parametersText(*reg[i]));
  }
  // `thrustcal lab effects` prints the catalogue: cli_test.cpp (LabCli.EffectsListing...)
}

TEST(LabRegistry, DocsLabMdListsTheRegistry) {
  std::ifstream f(THRUSTCAL_SOURCE_DIR "/docs/lab.md");
  ASSERT_TRUE(f) << "docs/lab.md not found";
  const std::string doc((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const std::string begin = "<!-- effects: begin -->\n", end = "<!-- effects: end -->";
  const auto a = doc.find(begin), b = doc.find(end);
  ASSERT_NE(a, std::string::npos) << "docs/lab.md has no " << begin;
  ASSERT_NE(b, std::string::npos) << "docs/lab.md has no " << end;
  EXPECT_EQ(doc.substr(a + begin.size(), b - a - begin.size()), lab::effects::markdownTable())
      << "docs/lab.md's effect table is not the registry's: replace it with the output of "
         "`thrustcal lab effects --markdown`";
}

// A small bench log with every column the catalogue uses: two motors, two voltages, a clock,
// a temperature and an air density.
lab::Dataset everyColumn() {
  lab::Dataset d;
  std::vector<double> pwm, force, vbat, t, temp, rho, motor;
  for (int r = 0; r < 4; ++r) {
    d.run_labels.push_back("run " + std::to_string(r));
    const double v = r % 2 ? 11.1 : 12.6, m = r < 2 ? 1 : 2;
    for (int k = 0; k < 25; ++k) {
      const double p = 1000 + 40.0 * k, x = std::max(0.0, (p - 1080) / 920) * v / 12.6;
      pwm.push_back(p);
      force.push_back(800 * x * x * (m == 2 ? 1.03 : 1.0) + 0.3 * std::sin(7.0 * k + r));
      vbat.push_back(v - 0.4 * x);
      t.push_back(30.0 * r + 1.2 * k);
      temp.push_back(25 + 0.1 * (30.0 * r + k));
      rho.push_back(1.2 - 0.001 * r + 0.0001 * k);
      motor.push_back(m);
      d.run.push_back(r);
    }
  }
  d.set("pwm_us", pwm), d.set("force_g", force), d.set("vbat_v", vbat), d.set("t_s", t);
  d.set("temp_c", temp), d.set("rho_kg_m3", rho), d.set("motor", motor);
  return d;
}

TEST(LabRegistry, AFitHasExactlyTheDocumentedParametersInTheirRanges) {
  const lab::Dataset d = everyColumn();
  for (const EffectDef* e : lab::effects::registry()) {
    if (e->role != Role::kEffect) continue;
    std::string spec = "curve+" + e->name;
    if (!e->needs.empty()) spec = "curve+" + e->needs + "+" + e->name;
    const lab::FitResult fit = lab::fitModel(d, lab::parseSpec(spec), nullptr, false, false);
    int own = 0;
    for (const auto& p : fit.params) {
      if (p.effect != e->name) continue;
      ++own;
      EXPECT_TRUE(documents(*e, p.name)) << e->name << " fits " << p.name << ", which its entry does not document";
      for (const auto& s : e->params)
        if (s.name == p.name && s.from_data.empty()) {
          EXPECT_EQ(p.unit, s.unit) << p.name;
          EXPECT_GE(p.value, s.lo) << p.name;
          EXPECT_LE(p.value, s.hi) << p.name;
        }
    }
    EXPECT_GT(own, 0) << e->name << " added no parameter to the fit";
  }
}

TEST(LabRegistry, EveryEffectSaysWhatSuggestsItAndItsAdviceNamesIt) {
  for (const EffectDef* e : lab::effects::registry()) {
    if (e->role != Role::kEffect) continue;
    const auto& s = e->suggests;
    EXPECT_FALSE(s.variables.empty() && s.evidence.empty()) << e->name << ": nothing would ever suggest it";
    EXPECT_NE(s.advice.find("add `" + e->name + "`"), std::string::npos) << e->name << ": " << s.advice;
    EXPECT_FALSE(s.still.empty()) << e->name << ": say what is left when it is in the model";
  }
}

TEST(LabRegistry, TheDiagnosisTakesItsSuggestionAndAdviceFromTheRegistry) {
  // given a sagging pack, diagnosed with voltage in the model
  lab::GenerateOptions o;
  o.hidden = "sag";
  o.noise_g = 0.5;
  lab::Dataset d = lab::generate(o);
  lab::addDerivedColumns(d);
  const lab::Diagnosis diag = lab::diagnose(d, lab::parseSpec("curve+deadband+voltage"), lab::Holdout::kNone);
  // then the suspect's effect is the entry whose variables name vbat_v and whose needs are met,
  // and its words are that entry's advice
  const auto* sag = lab::effects::find("sag");
  ASSERT_NE(sag, nullptr);
  ASSERT_FALSE(diag.variables.empty());
  EXPECT_EQ(diag.variables.front().effects.front(), sag->name);
  EXPECT_NE(diag.variables.front().advice.find(sag->suggests.advice), std::string::npos) << diag.variables.front().advice;
}

TEST(LabRegistry, AnalysisNamesNoEffect) {
  // a new effect is its file and its registry line: the diagnosis's sources (the ranking, the
  // verdict, the ladder) name none of them
  for (const char* file : {"analysis.cpp", "verdict.cpp", "ladder.cpp"}) {
    std::ifstream f(std::string(THRUSTCAL_SOURCE_DIR "/tools/lab/src/") + file);
    ASSERT_TRUE(f) << file;
    std::string src((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    // --holdout voltage is a kind of hold-out (runs grouped by voltage), not the effect
    const auto a = src.find("Holdout parseHoldout(");
    if (a != std::string::npos) src.erase(a, src.find("\n}\n", a) - a);
    for (const EffectDef* e : lab::effects::registry()) {
      if (e->role == Role::kExpression) continue;
      EXPECT_EQ(src.find("\"" + e->name + "\""), std::string::npos) << file << " names \"" << e->name << "\"";
      EXPECT_EQ(src.find("`" + e->name + "`"), std::string::npos) << file << " names `" << e->name << "`";
    }
  }
}

}  // namespace

// RCbenchmark / Tyto Robotics exports as the software writes them (the column layouts of
// published logs: every line ending in a comma, µs in UTF-8, units in parentheses, empty servo
// columns, an App message column), generated here from the plant (no third-party log is
// committed): read as they come, each variable once under the lab's name and unit, every
// reader decision said in a note.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "lab/analysis.hpp"
#include "lab/dataset.hpp"
#include "lab/generate.hpp"

namespace {

using lab::Dataset;
using lab::InputError;
using lab::parseText;
using lab::ReadOptions;

Dataset plant(const char* hidden = "sag") {
  lab::GenerateOptions o;
  o.hidden = hidden;
  o.noise_g = 0.5;
  return lab::generate(o);
}

std::string stand(const Dataset& d, const char* series, const char* thrust_unit, bool negative = false,
                  const char* torque_unit = "N·m") {
  lab::StandLayout l;
  l.series = series;
  l.thrust_unit = thrust_unit;
  l.torque_unit = torque_unit;
  l.negative_thrust = negative;
  return lab::toStandCsv(d, l);
}

bool anyNote(const Dataset& d, const std::string& text) {
  for (const auto& n : d.notes)
    if (n.find(text) != std::string::npos) return true;
  return false;
}

TEST(LabRealLayout, GeneratedFilesHaveTheRcbenchmarkShape) {
  const std::string csv = stand(plant(), "1520", "gf");
  // the 1520 header as the software writes it, every line closed by a comma
  EXPECT_EQ(csv.rfind("Time (s),ESC signal (\xC2\xB5s),Servo 1 (\xC2\xB5s),Servo 2 (\xC2\xB5s),Servo 3 (\xC2\xB5s),"
                      "Thrust (gf),Voltage (V),Current (A),Motor Electrical Speed (RPM),Motor Optical Speed (RPM),"
                      "Electrical Power (W),Overall Efficiency (gf/W),App message,\n",
                      0),
            0u);
  EXPECT_NE(csv.find(",Tare done,\n"), std::string::npos);
  std::size_t lines = 0, closed = 0;
  for (std::size_t at = csv.find('\n'); at != std::string::npos; at = csv.find('\n', at + 1)) {
    ++lines;
    closed += csv[at - 1] == ',' ? 1 : 0;
  }
  EXPECT_EQ(lines, closed);
}

TEST(LabRealLayout, Rcbenchmark1520InGramsForceWithTrailingCommasAndAppMessageReadsAsOneVariableEach) {
  // given the plant's sweeps as an RCbenchmark 1520 export in gf
  const Dataset truth = plant();
  // when read as it comes
  const Dataset d = parseText(stand(truth, "1520", "gf"), "StepsTest_1520.csv", ReadOptions());
  // then each variable is there once, under the lab's name, in the lab's unit
  ASSERT_EQ(d.rows(), truth.rows());
  for (const char* name : {"t_s", "pwm_us", "force_g", "vbat_v", "current_a", "rpm", "power_w"})
    EXPECT_TRUE(d.has(name)) << name;
  for (const char* raw : {"Voltage_V", "Current_A", "ESC_signal_us", "ESC_signal_s", "Thrust_gf", "Time_s",
                          "Servo_1_us", "App_message", "Motor_Optical_Speed_RPM"})
    EXPECT_FALSE(d.has(raw)) << raw;
  EXPECT_NEAR(d.col("force_g")[100], truth.col("force_g")[100], 1e-4);
  EXPECT_DOUBLE_EQ(d.col("pwm_us")[100], truth.col("pwm_us")[100]);
  // the file's own name and unit stay as the axis label
  EXPECT_EQ(lab::axisLabel(d, "pwm_us"), "ESC signal (\xC2\xB5s)");
  EXPECT_EQ(lab::axisLabel(d, "force_g"), "Thrust (g)");
  // and what was set aside is said
  EXPECT_TRUE(anyNote(d, "column 'App message' holds text ('Tare done' on line 2); ignored"));
  EXPECT_TRUE(anyNote(d, "'Servo 1 (\xC2\xB5s)', 'Servo 2 (\xC2\xB5s)', 'Servo 3 (\xC2\xB5s)'"));
}

struct ThrustUnit {
  const char* unit;
  double grams_per_unit;
};

TEST(LabRealLayout, EveryThrustUnitTheSoftwareWritesBecomesGrams) {
  const Dataset truth = plant();
  const ThrustUnit units[] = {{"N", 101.97162}, {"kgf", 1000}, {"gf", 1}, {"lbf", 453.59237}, {"ozf", 28.349523}};
  for (const auto& u : units) {
    const Dataset d = parseText(stand(truth, "1585", u.unit), "ramp.csv", ReadOptions());
    ASSERT_TRUE(d.has("force_g")) << u.unit;
    for (std::size_t i : {50u, 150u, 250u}) {
      const double want = truth.col("force_g")[i];
      EXPECT_NEAR(d.col("force_g")[i], want, 1e-5 * std::fabs(want) + 1e-6) << u.unit;
    }
    EXPECT_NE(lab::axisLabel(d, "force_g").find(std::string("Thrust (g)") + (u.grams_per_unit == 1 ? "" : ", logged in ")),
              std::string::npos)
        << u.unit;
  }
}

TEST(LabRealLayout, TorqueInNewtonMetresOrOunceInchesBecomesTorqueNm) {
  const Dataset truth = plant();
  for (const char* unit : {"N·m", "ozf·in"}) {
    const Dataset d = parseText(stand(truth, "1585", "N", false, unit), "ramp.csv", ReadOptions());
    ASSERT_TRUE(d.has("torque_nm")) << unit;
    // the 1585 logs the reaction torque, negative for a thrusting propeller
    EXPECT_NEAR(d.col("torque_nm")[200], -truth.col("torque_nm")[200], 1e-6 + 1e-5 * truth.col("torque_nm")[200]) << unit;
  }
}

TEST(LabRealLayout, ThrustLoggedNegativeIsFlippedSayingTheExplicitMapAndAMapKeepsItsOwnSign) {
  const Dataset truth = plant();
  const std::string csv = stand(truth, "1585", "N", /*negative=*/true);
  // given a 6S-style stand logging thrust negative in newtons: the reader flips it and says how
  const Dataset d = parseText(csv, "6S_ramp.csv", ReadOptions());
  EXPECT_GT(d.col("force_g")[200], 0);
  EXPECT_TRUE(anyNote(d, "thrust logged negative")) << d.notes.front();
  EXPECT_TRUE(anyNote(d, "--map 'force_g=-Thrust (N)*101.97"));
  // a --map with a unary minus is the same, explicit, and no flip is applied on top
  ReadOptions minus;
  minus.maps = {lab::parseColumnMap("force_g=-Thrust (N)*101.971621")};
  const Dataset m = parseText(csv, "6S_ramp.csv", minus);
  EXPECT_NEAR(m.col("force_g")[200], d.col("force_g")[200], 1e-6 * d.col("force_g")[200]);
  EXPECT_FALSE(anyNote(m, "sign flipped"));
  // so is a negative factor
  ReadOptions factor;
  factor.maps = {lab::parseColumnMap("force_g=Thrust (N)*-101.971621")};
  EXPECT_NEAR(parseText(csv, "6S_ramp.csv", factor).col("force_g")[200], d.col("force_g")[200], 1e-3);
  // a --map that leaves the thrust negative is refused with the fix, never flipped silently
  ReadOptions plain;
  plain.maps = {lab::parseColumnMap("force_g=Thrust (N)*101.97")};
  try {
    parseText(csv, "6S_ramp.csv", plain);
    FAIL() << "a negative mapped force was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--map 'force_g=-Thrust (N)*101.97'"), std::string::npos) << e.what();
  }
}

TEST(LabRealLayout, ByteOrderMarkCrlfAndOldMacLineEndsReadTheSame) {
  const std::string csv = stand(plant(), "1520", "gf");
  const Dataset ref = parseText(csv, "a.csv", ReadOptions());
  std::string crlf, cr;
  for (char c : csv) {
    crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
    cr += c == '\n' ? '\r' : c;
  }
  for (const std::string& variant : {"\xEF\xBB\xBF" + csv, crlf, cr}) {
    const Dataset d = parseText(variant, "b.csv", ReadOptions());
    ASSERT_EQ(d.rows(), ref.rows());
    EXPECT_EQ(d.names, ref.names);
    EXPECT_DOUBLE_EQ(d.col("force_g").back(), ref.col("force_g").back());
  }
}

TEST(LabRealLayout, MicroSignsOfEverySpreadsheetReadAsMicroseconds) {
  for (const char* us : {"\xC2\xB5s", "\xCE\xBCs", "us", "\xB5s", "\xED\x83\x8E"}) {
    const std::string csv = std::string("Time (s),ESC signal (") + us + "),Thrust (kgf),\n0,1100,0.010,\n0.1,1500,0.300,\n";
    const Dataset d = parseText(csv, "us.csv", ReadOptions());
    ASSERT_TRUE(d.has("pwm_us")) << us;
    EXPECT_DOUBLE_EQ(d.col("pwm_us")[1], 1500) << us;
    EXPECT_NEAR(d.col("force_g")[1], 300, 1e-9) << us;
  }
  // an identifier keeps the micro as `u`: never seconds
  EXPECT_EQ(lab::sanitizeName("Servo 1 (\xC2\xB5s)"), "Servo_1_us");
}

TEST(LabRealLayout, ALastLineCutShortIsDroppedWithANoteAndAShortLineInsideIsAnError) {
  const std::string csv = stand(plant(), "1585", "N");
  const Dataset whole = parseText(csv, "ramp.csv", ReadOptions());
  // given the file cut in the middle of its last line (a stand unplugged while logging)
  const std::string cut = csv.substr(0, csv.size() - 40);
  // when read, then every complete row is there and the cut one is dropped, with a note
  const Dataset d = parseText(cut, "ramp.csv", ReadOptions());
  EXPECT_EQ(d.rows(), whole.rows() - 1);
  EXPECT_TRUE(anyNote(d, "is cut short")) << d.notes.back();
  // cut right after a comma: the trailing comma is missing, the line is still incomplete
  const std::size_t last = csv.rfind('\n', csv.size() - 2);
  const std::string after_comma = csv.substr(0, csv.rfind(',', csv.size() - 3) + 1);
  ASSERT_GT(after_comma.size(), last);
  EXPECT_EQ(parseText(after_comma, "ramp.csv", ReadOptions()).rows(), whole.rows() - 1);
  // a short line before the end is damage, not a cut: an error with its line
  std::string inside = csv;
  const std::size_t third = inside.find('\n', inside.find('\n', inside.find('\n') + 1) + 1);
  inside.erase(inside.rfind(',', third - 2) - 8, 9);
  EXPECT_THROW(parseText(inside, "ramp.csv", ReadOptions()), InputError);
}

TEST(LabRealLayout, ADuplicatedColumnNameIsRefusedNotFirstCopyWins) {
  try {
    parseText("pwm_us,force_g,vbat_v,force_g\n1100,5,12,6\n1200,9,12,10\n", "dup.csv", ReadOptions());
    FAIL() << "a duplicated column was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 1u);
    EXPECT_EQ(e.column(), 23u);
    EXPECT_NE(std::string(e.what()).find("column 'force_g' appears twice"), std::string::npos) << e.what();
  }
  // two columns that would be one variable are refused too, naming both and the choice
  try {
    parseText("ESC signal (us),Thrust (N),Thrust (kgf),\n1100,0.1,0.0102,\n1200,0.2,0.0204,\n", "two.csv",
              ReadOptions());
    FAIL() << "two thrust columns were accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'Thrust (N)' and 'Thrust (kgf)' are both force_g"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("--map force_g="), std::string::npos) << e.what();
  }
}

TEST(LabRealLayout, NotFiniteDrivesOrForcesAreRefusedOtherCellsAndRowsWithoutAForceAreNotedAndDropped) {
  for (const char* bad : {"inf", "-inf", "1e400", "Infinity"}) {
    try {
      parseText(std::string("pwm_us,force_g\n1100,5\n1200,") + bad + "\n", "nan.csv", ReadOptions());
      ADD_FAILURE() << bad << " accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.line(), 3u) << bad;
      EXPECT_EQ(e.column(), 6u) << bad;
      EXPECT_NE(std::string(e.what()).find("not a finite number"), std::string::npos) << e.what();
    }
  }
  // in a column the lab does not use (a stand's efficiency over zero power), not logged there
  const Dataset eff = parseText("pwm_us,force_g,eff_g_per_w\n1100,5,inf\n1200,9,3.1\n", "eff.csv", ReadOptions());
  EXPECT_TRUE(std::isnan(eff.col("eff_g_per_w")[0]));
  EXPECT_TRUE(anyNote(eff, "column 'eff_g_per_w' has 1 cell(s) that are not finite numbers ('inf' on line 2)"));
  const Dataset d = parseText("pwm_us,force_g,vbat_v\n1100,5,12\n1200,nan,12\n1300,,12\n1400,30,NaN\n", "gaps.csv",
                              ReadOptions());
  EXPECT_EQ(d.rows(), 2u);
  EXPECT_TRUE(anyNote(d, "dropped 2 row(s) with no number for pwm_us or force_g (line 3, 4)")) << d.notes.front();
  EXPECT_TRUE(std::isnan(d.col("vbat_v")[1]));  // another column's gap stays a gap
}

TEST(LabRealLayout, WhereKeepsTheRowsAskedForAndCountsTheRest) {
  Dataset d = parseText(stand(plant("none"), "1585", "N"), "ramp.csv", ReadOptions());
  const std::size_t before = d.rows();
  const lab::RowSelection sel = lab::selectRows(d, "pwm_us < 1840 and rpm > 0 or pwm_us == 1000");
  EXPECT_EQ(sel.kept + sel.dropped, before);
  EXPECT_EQ(sel.kept, d.rows());
  for (double p : d.col("pwm_us")) EXPECT_LT(p, 1840);
  EXPECT_GT(sel.dropped, 0u);
  // a bad expression names its position and the columns
  try {
    lab::selectRows(d, "pwm < 1840");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("pwm_us"), std::string::npos) << e.what();
  }
  EXPECT_THROW(lab::selectRows(d, "pwm_us > 5000"), std::invalid_argument);  // keeps nothing
}

TEST(LabRealLayout, ForceFallingAsTheDriveRisesIsFoundWithThePwmWhereItStarts) {
  Dataset d = plant("none");
  std::vector<double> f = d.col("force_g");
  const auto& p = d.col("pwm_us");
  // a current limit above 1750 us: the force falls from what it had there
  std::vector<double> at_limit(d.runs(), 0.0);
  for (std::size_t i = 0; i < f.size(); ++i)
    if (p[i] == 1750) at_limit[static_cast<std::size_t>(d.run[i])] = f[i];
  for (std::size_t i = 0; i < f.size(); ++i)
    if (p[i] > 1750) f[i] = at_limit[static_cast<std::size_t>(d.run[i])] * (1.0 - (p[i] - 1750) / 500.0);
  const Dataset clean = d;
  d.set("force_g", f);
  const auto found = lab::findForceCollapse(d);
  ASSERT_EQ(found.size(), d.runs());  // every run
  for (const auto& c : found) {
    EXPECT_NEAR(c.peak_pwm_us, 1750, 25);
    EXPECT_LT(c.top_force_g, c.peak_force_g);
    EXPECT_NE(lab::describe(c).find("--where 'pwm_us < 1750'"), std::string::npos) << lab::describe(c);
  }
  EXPECT_TRUE(lab::findForceCollapse(clean).empty());
}

}  // namespace

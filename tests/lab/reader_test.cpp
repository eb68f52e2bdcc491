// Readers: the project's CSV, a captured gather_store log, RCbenchmark/Tyto exports, column
// mappings; bad files give file:line:column errors; random mutations never crash.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "lab/dataset.hpp"

namespace {

using lab::Dataset;
using lab::InputError;
using lab::parseText;
using lab::ReadOptions;

const char* kProjectCsv =
    "# bench log\n"
    "t_s,motor,pwm_us,force_g,vbat_v,humidity_pct\n"
    "0.2,0,1100,1.5,12.5,40\n"
    "0.4,0,1200,20.25,12.4,41\n"
    "# a comment in the middle\n"
    "0.6,1,1300,60,12.3,42\n";

TEST(LabReader, ReadsProjectCsvWithCommentsAndCandidateColumns) {
  // given a project CSV with comments and an extra numeric column
  // when it is parsed
  const Dataset d = parseText(kProjectCsv, "log.csv", ReadOptions());
  // then every row and column is there, and the motor column splits the runs
  ASSERT_EQ(d.rows(), 3u);
  EXPECT_DOUBLE_EQ(d.col("force_g")[1], 20.25);
  EXPECT_DOUBLE_EQ(d.col("humidity_pct")[2], 42);
  EXPECT_EQ(d.runs(), 2u);
  EXPECT_EQ(d.run[0], d.run[1]);
  EXPECT_NE(d.run[1], d.run[2]);
}

TEST(LabReader, SkipsConsoleLinesOfACapturedGatherStoreLog) {
  // given a terminal capture: prompts, progress text, the sweep header and rows, twice
  const std::string log =
      "gs> motor 2\r\n"
      "motor 2 selected\r\n"
      "gs> sweep\r\n"
      "# sweep 1000..1200 step 100, settle 200 ms\r\n"
      "pwm_us,force_g,vbat_v,t_s,motor,dir\r\n"
      "1000,0.0,12.41,0.2,2,1\r\n"
      "progress 50%\r\n"
      "1100,3.5,12.38,0.4,2,1\r\n"
      "1200,25.0,12.30,0.6,2,1\r\n"
      "gs> sweep\r\n"
      "pwm_us,force_g,vbat_v,t_s,motor,dir\r\n"
      "1000,0.1,11.01,0.2,2,1\r\n"
      "1100,2.9,10.98,0.4,2,1\r\n";
  // when it is parsed
  const Dataset d = parseText(log, "capture.txt", ReadOptions());
  // then the five samples are read, the repeated header starts a second run, and the skipped
  // console text is reported
  ASSERT_EQ(d.rows(), 5u);
  EXPECT_EQ(d.runs(), 2u);
  EXPECT_DOUBLE_EQ(d.col("vbat_v")[3], 11.01);
  ASSERT_FALSE(d.notes.empty());
  EXPECT_NE(d.notes.back().find("skipped"), std::string::npos);
}

TEST(LabReader, ReadsTytoExportInNewtonsWithNegativeThrustAsLogged) {
  // given an RCbenchmark/Tyto export (comma separated, thrust in N, logged negative)
  const std::string tyto =
      "Time (s),ESC signal (\xC2\xB5s),Thrust (N),Voltage (V),Current (A),Motor Electrical Speed (RPM)\n"
      "0.1,1100,-0.0981,12.1,0.5,3000\n"
      "0.2,1500,-2.942,11.9,6.0,21000\n";
  // when it is parsed
  const Dataset d = parseText(tyto, "tyto.csv", ReadOptions());
  // then its columns map to the project's names, newtons become grams, the sign is thrust-positive
  ASSERT_TRUE(d.has("pwm_us"));
  ASSERT_TRUE(d.has("force_g"));
  EXPECT_DOUBLE_EQ(d.col("pwm_us")[1], 1500);
  EXPECT_NEAR(d.col("force_g")[1], 300.0, 0.01);
  EXPECT_NEAR(d.col("vbat_v")[0], 12.1, 1e-12);
  EXPECT_NEAR(d.col("rpm")[1], 21000, 1e-9);
  EXPECT_NEAR(d.col("t_s")[0], 0.1, 1e-12);
}

TEST(LabReader, ReadsSemicolonSeparatedTytoExportWithDecimalCommaAndKgf) {
  const std::string tyto =
      "Time (s);ESC signal (us);Thrust (kgf);Voltage (V)\n"
      "0,1;1100;0,010;12,1\n"
      "0,2;1500;0,300;11,9\n";
  const Dataset d = parseText(tyto, "tyto_eu.csv", ReadOptions());
  EXPECT_NEAR(d.col("force_g")[1], 300.0, 1e-9);
  EXPECT_NEAR(d.col("vbat_v")[1], 11.9, 1e-12);
}

TEST(LabReader, MapsColumnsOfForeignFilesAndDropsTheForceSource) {
  // given the Crazyflie layout (total weight of four motors, pwm 0..65535)
  const std::string cf = "weight[g],pwm,vbat[V],rpm1\n-1.0,0,3.9,0\n40.0,60000,3.1,20000\n";
  ReadOptions ro;
  ro.maps = {lab::parseColumnMap("force_g=weight[g]/4"), lab::parseColumnMap("pwm_us=pwm"),
             lab::parseColumnMap("vbat_v=vbat[V]")};
  // when it is read with the mapping
  const Dataset d = parseText(cf, "cf.csv", ro);
  // then force is per motor, and the source columns are gone (they would leak the answer)
  EXPECT_DOUBLE_EQ(d.col("force_g")[1], 10.0);
  EXPECT_DOUBLE_EQ(d.col("pwm_us")[1], 60000);
  EXPECT_DOUBLE_EQ(d.col("vbat_v")[1], 3.1);
  EXPECT_FALSE(d.has("weight_g"));
  EXPECT_FALSE(d.has("pwm"));
  EXPECT_TRUE(d.has("rpm1"));
}

TEST(LabReader, ParsesMappingChainsAndRejectsMalformedOnes) {
  const auto m = lab::parseColumnMap("pwm_us=pwm*1000/65535+1000");
  EXPECT_EQ(m.source, "pwm");
  ASSERT_EQ(m.ops.size(), 3u);
  EXPECT_EQ(m.ops[2].first, '+');
  for (const char* bad : {"force_g", "=x", "force_g=", "force g=x", "force_g=x/0"})
    EXPECT_THROW(lab::parseColumnMap(bad), std::invalid_argument) << bad;
}

struct BadFile {
  const char* text;
  std::size_t line;
  std::size_t column;
  const char* says;
};

TEST(LabReader, ReportsBadFilesWithLineColumnAndWhatWasExpected) {
  const BadFile cases[] = {
      {"pwm_us,force_g\n1000,1.0\n1100,abc\n", 3, 6, "expected a number in column 'force_g'"},
      {"pwm_us,force_g\n1000,1.0,7\n", 2, 10, "expected 2 fields"},
      {"pwm_us,force_g\n1000\n", 2, 5, "expected 2 fields"},
      {"1000,1.0\n1100,2.0\n", 1, 1, "expected a header line"},
      {"pwm_us,force_g\n", 1, 1, "expected data rows"},
      {"pwm_us,force_g\n1000,\n", 2, 6, "expected a number for force_g"},
      {"", 1, 1, "expected a header line"},
  };
  for (const auto& c : cases) {
    try {
      parseText(c.text, "bad.csv", ReadOptions());
      ADD_FAILURE() << "no error for: " << c.text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.line(), c.line) << c.text;
      EXPECT_EQ(e.column(), c.column) << c.text;
      EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind("bad.csv:", 0), 0u) << e.what();
    }
  }
}

TEST(LabReader, NamesTheMissingRequiredColumnAndTheMapToUse) {
  const std::string path = std::string(THRUSTCAL_LAB_TMP_DIR) + "/no_force.csv";
  std::filesystem::create_directories(THRUSTCAL_LAB_TMP_DIR);
  {
    std::ofstream f(path);
    f << "pwm_us,weight\n1000,1\n";
  }
  try {
    lab::readFiles({path}, ReadOptions());
    FAIL() << "missing force_g accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("force_g"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("--map"), std::string::npos);
  }
}

TEST(LabReader, RandomMutationsOfValidFilesParseOrFailCleanly) {
  // given valid files of each format, mutated at random (bytes replaced, inserted, deleted,
  // lines duplicated or cut)
  const std::string seeds[] = {
      kProjectCsv,
      "gs> sweep\npwm_us,force_g,vbat_v,t_s,motor,dir\n1000,0.0,12.4,0.2,0,1\n1100,3.5,12.3,0.4,0,1\n",
      "Time (s);ESC signal (us);Thrust (kgf);Voltage (V)\n0,1;1100;0,010;12,1\n0,2;1500;0,300;11,9\n",
  };
  const char alphabet[] = "0123456789.,;-+eE#\n\r \"abcxyz_()[]/\t\xC2\xB5";
  std::mt19937 rng(20240601);
  int parsed = 0, rejected = 0;
  for (int iter = 0; iter < 4000; ++iter) {
    std::string s = seeds[iter % 3];
    const int edits = 1 + static_cast<int>(rng() % 6);
    for (int e = 0; e < edits && !s.empty(); ++e) {
      const std::size_t pos = rng() % s.size();
      const char c = alphabet[rng() % (sizeof(alphabet) - 1)];
      switch (rng() % 5) {
        case 0: s[pos] = c; break;
        case 1: s.insert(s.begin() + static_cast<long>(pos), c); break;
        case 2: s.erase(pos, 1 + rng() % 3); break;
        case 3: s = s.substr(0, pos); break;
        default: {
          const std::size_t nl = s.find('\n', pos);
          if (nl != std::string::npos) s.insert(nl + 1, s.substr(pos, nl + 1 - pos));
        }
      }
    }
    // when parsed: then it is data or an InputError, nothing else
    try {
      const Dataset d = parseText(s, "fuzz.csv", ReadOptions());
      for (const auto& c : d.columns) ASSERT_EQ(c.size(), d.rows());
      ASSERT_EQ(d.run.size(), d.rows());
      ++parsed;
    } catch (const InputError& e) {
      ASSERT_EQ(std::string(e.what()).rfind("fuzz.csv:", 0), 0u);
      ++rejected;
    }
  }
  // both outcomes happen (the mutations are neither all harmless nor all fatal)
  EXPECT_GT(parsed, 100);
  EXPECT_GT(rejected, 100);
}

}  // namespace

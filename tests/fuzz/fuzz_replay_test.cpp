// The fuzz targets (fuzz_targets.hpp) on every build, deterministic: for each target its
// seeds are written to FUZZ_CORPUS_DIR/<target>/ (the libFuzzer binaries of the `fuzz` preset
// start from them), replayed, then every committed regression input of
// tests/fuzz/regressions/<target>/ (crashes libFuzzer found, kept as files), then mutations of
// the seeds and purely random inputs from a fixed PRNG seed. A broken promise aborts the test
// binary with the target's message; under the sanitizer build (tools/test.sh) any memory or
// undefined-behaviour error does too. FUZZ_REPLAY_CASES (environment) changes the number of
// generated inputs per target (default 2000; lab_expression, which fits a model per input,
// runs a tenth of them).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_targets.hpp"

namespace {

namespace fs = std::filesystem;

struct Prng {  // xorshift64*: the same inputs on every machine
  uint64_t s;
  uint64_t next() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return s * 2685821657736338717ull;
  }
  std::size_t below(std::size_t n) { return n ? static_cast<std::size_t>(next() % n) : 0; }
};

// One libFuzzer-like mutation of `in` (bit flips, interesting bytes, inserts, deletes, copies,
// splices with another seed, truncation).
std::string mutate(std::string in, const std::vector<std::string>& seeds, Prng& rng) {
  static const char kInteresting[] = {'\0', '\xFF', '\n', '\r', ':', ',', '-', '.', '0', '9', 'e', '+', '*', '('};
  const int ops = 1 + static_cast<int>(rng.below(4));
  for (int op = 0; op < ops; ++op) {
    const std::size_t at = rng.below(in.size() + 1);
    switch (rng.below(7)) {
      case 0:
        if (!in.empty()) in[at % in.size()] ^= static_cast<char>(1u << rng.below(8));
        break;
      case 1:
        if (!in.empty()) in[at % in.size()] = kInteresting[rng.below(sizeof kInteresting)];
        break;
      case 2:
        in.insert(at, 1 + rng.below(4), static_cast<char>(rng.next()));
        break;
      case 3:
        if (!in.empty()) in.erase(at % in.size(), 1 + rng.below(8));
        break;
      case 4:
        if (!in.empty()) {
          const std::size_t from = rng.below(in.size());
          in.insert(at, in.substr(from, 1 + rng.below(16)));
        }
        break;
      case 5: {
        const std::string& other = seeds[rng.below(seeds.size())];
        if (!other.empty()) {
          const std::size_t from = rng.below(other.size());
          in = in.substr(0, at) + other.substr(from, rng.below(64) + 1);
        }
        break;
      }
      default:
        in.resize(rng.below(in.size() + 1));
        break;
    }
  }
  return in;
}

std::string readFile(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void run(const fuzz::Target& t, const std::string& input) {
  t.run(reinterpret_cast<const uint8_t*>(input.data()), input.size());
}

int casesFor(const fuzz::Target& t) {
  int n = 2000;
  if (const char* env = std::getenv("FUZZ_REPLAY_CASES")) n = std::max(0, std::atoi(env));
  return std::string(t.name) == "lab_expression" ? n / 10 : n;
}

class FuzzReplay : public ::testing::TestWithParam<std::string> {};

TEST_P(FuzzReplay, SeedsRegressionsMutationsAndRandomInputsKeepEveryPromise) {
  const fuzz::Target* t = fuzz::findTarget(GetParam());
  ASSERT_NE(t, nullptr);
  // given: the seed corpus, written where the libFuzzer binaries look for it
  const std::vector<std::string> seeds = t->seeds();
  ASSERT_FALSE(seeds.empty());
  const fs::path corpus = fs::path(FUZZ_CORPUS_DIR) / t->name;
  fs::create_directories(corpus);
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    std::ofstream out(corpus / ("seed-" + std::to_string(i)), std::ios::binary | std::ios::trunc);
    out << seeds[i];
  }
  // when / then: seeds, committed regressions, mutations, random bytes
  for (const auto& s : seeds) run(*t, s);
  int regressions = 0;
  const fs::path kept = fs::path(FUZZ_REGRESSION_DIR) / t->name;
  if (fs::exists(kept)) {
    for (const auto& e : fs::directory_iterator(kept)) {
      if (!e.is_regular_file()) continue;
      SCOPED_TRACE(e.path().string());
      run(*t, readFile(e.path()));
      ++regressions;
    }
  }
  Prng rng{0x9E3779B97F4A7C15ull ^ std::hash<std::string>{}(t->name)};
  const int cases = casesFor(*t);
  for (int i = 0; i < cases; ++i) {
    std::string input;
    if (i % 4 == 3) {
      input.resize(rng.below(600));
      for (char& c : input) c = static_cast<char>(rng.next());
    } else {
      input = seeds[rng.below(seeds.size())];
      for (int depth = 1 + static_cast<int>(rng.below(3)); depth > 0; --depth) input = mutate(input, seeds, rng);
    }
    run(*t, input);
  }
  RecordProperty("seeds", std::to_string(seeds.size()));
  RecordProperty("regressions", std::to_string(regressions));
  RecordProperty("generated_cases", std::to_string(cases));
  std::printf("%s: %zu seeds, %d regressions, %d generated inputs\n", t->name, seeds.size(), regressions, cases);
}

std::vector<std::string> names() {
  std::vector<std::string> n;
  for (const auto& t : fuzz::targets()) n.push_back(t.name);
  return n;
}

INSTANTIATE_TEST_SUITE_P(Target, FuzzReplay, ::testing::ValuesIn(names()),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

}  // namespace

// Issue 8, item 8 (console part; docs/safety.md "Fuzzing"): deterministic fuzzing of both
// consoles on the real images in simavr. Seeded, so every run sends the same bytes.
//
// Each image gets 100 batches of 100 lines (10,000 lines) of: random bytes,
// valid-looking commands (some with a checksum, some with a wrong one), single-byte mutations
// of them, framing errors, over-long lines, floods without a line end, all sent as one burst
// or line by line; every third batch also aborts a lift-off (read_run) or a sweep
// (gather_store) mid-line. Strict mode is on for every other group of five batches.
// After every batch:
//  - the prompt still answers: a checksummed "status" gets its reply (the health line);
//  - no reset: the board never reset, one "reset:" line since power-on;
//  - motors at 1000 us when they should be: read_run after 600 ms without a keep-alive,
//    gather_store once no sweep runs; with strict on, no ESC pulse above 1000 us at all
//    during a batch that sent no intact checksummed spin command;
//  - EEPROM byte-identical, except the slots a documented store or erase reported
//    ("stored ... motor N", "erased motor N"; gather_store only).
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <chrono>
#include <cstdlib>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "safety_support.hpp"
#include "text_match.hpp"

namespace {

using safety::contains;
using safety::withSum;

constexpr int kBatches = 100;
constexpr int kLinesPerBatch = 100;

// One byte to send; framing errors are sent garbled.
struct Item {
  uint8_t byte;
  bool framing_error;
};

class Fuzzer {
 public:
  explicit Fuzzer(uint64_t seed) : rng_(seed) {}
  int uniform(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  bool chance(double p) { return std::bernoulli_distribution(p)(rng_); }
  template <class T>
  const T& pick(const std::vector<T>& v) { return v[static_cast<std::size_t>(uniform(0, static_cast<int>(v.size()) - 1))]; }

  std::string randomWord() {
    std::string w;
    for (int i = uniform(1, 8); i > 0; --i) w += static_cast<char>('a' + uniform(0, 25));
    return w;
  }
  std::string randomBytes(int max_len) {
    std::string s;
    for (int i = uniform(1, max_len); i > 0; --i) {
      uint8_t b = static_cast<uint8_t>(uniform(0, 255));
      if (b == '\r' || b == '\n') b = 'z';
      s += static_cast<char>(b);
    }
    return s;
  }
  // One single-byte change: substitute, drop or insert.
  std::string mutate(std::string s) {
    if (s.empty()) return "q";
    const std::size_t at = static_cast<std::size_t>(uniform(0, static_cast<int>(s.size()) - 1));
    switch (uniform(0, 2)) {
      case 0: {
        char c;
        do c = static_cast<char>(uniform(0x20, 0x7E)); while (c == s[at]);
        s[at] = c;
        break;
      }
      case 1: s.erase(at, 1); break;
      default: s.insert(at, 1, static_cast<char>(uniform(0x20, 0x7E))); break;
    }
    return s;
  }
  std::string terminator() {
    switch (uniform(0, 3)) {
      case 0: return "\n";
      case 1: return "\r\n";
      default: return "\r";
    }
  }

 private:
  std::mt19937_64 rng_;
};

// A line of a batch: what to send, and what it is for the checks.
struct FuzzLine {
  std::vector<Item> items;
  bool spin_checked = false;  // an intact, checksummed command that may spin a motor
};

struct Generator {
  virtual ~Generator() = default;
  virtual std::string command(Fuzzer& f) = 0;         // valid-looking, may be out of range
  virtual bool spins(const std::string& line) = 0;    // could this command spin a motor?
};

struct ReadRunGrammar : Generator {
  std::string command(Fuzzer& f) override {
    switch (f.uniform(0, 11)) {
      case 0: return fmt::format("f {}", f.uniform(-5, 600));
      case 1: return fmt::format("f {} {}", f.uniform(-1, 5), f.uniform(-5, 600));
      case 2: return "stop";
      case 3: return "status";
      case 4: return "help";
      case 5: return f.pick(std::vector<std::string>{"stream on", "stream off", "stream x"});
      case 6: return fmt::format("rate {}", f.uniform(20, 500));
      case 7: return fmt::format("liftoff {} {} {}", f.uniform(-5, 600), f.uniform(0, 800), f.uniform(0, 800));
      case 8: return "strict maybe";
      case 9: return "";
      case 10: return f.randomWord();
      default: return fmt::format("f {}", f.uniform(0, 300));
    }
  }
  bool spins(const std::string& line) override {
    return line.rfind("f ", 0) == 0 || line.rfind("liftoff", 0) == 0;
  }
};

struct GatherStoreGrammar : Generator {
  std::string command(Fuzzer& f) override {
    switch (f.uniform(0, 16)) {
      case 0: return "help";
      case 1: return fmt::format("motor {}", f.uniform(-1, 5));
      case 2: return fmt::format("plate {}", f.uniform(-10, 600));
      case 3: return "weigh";
      case 4: return "tare";
      case 5: return fmt::format("cal {}", f.uniform(-5, 1000));
      case 6: return fmt::format("span {}", f.uniform(-5, 1000));
      case 7: return fmt::format("range {} {}", f.uniform(900, 2100), f.uniform(900, 2100));
      case 8: return fmt::format("step {}", f.uniform(0, 150));
      case 9: return f.chance(0.2) ? "settle auto" : fmt::format("settle {}", f.uniform(-1, 12000));
      case 10: return "sweep";
      case 11: return f.pick(std::vector<std::string>{"store 1", "store 2", "store v2", "store x"});
      case 12: return "show";
      case 13: return "erase";
      case 14: return "status";
      case 15: return f.randomWord();
      default: return "";
    }
  }
  bool spins(const std::string& line) override { return line == "sweep"; }
};

FuzzLine makeLine(Fuzzer& f, Generator& g, bool strict) {
  FuzzLine out;
  auto add = [&](const std::string& s) {
    for (char c : s) out.items.push_back({static_cast<uint8_t>(c), false});
  };
  const int kind = f.uniform(0, 99);
  if (kind < 40) {  // valid-looking command, checksummed in strict mode (mostly)
    const std::string cmd = g.command(f);
    const bool sum = strict ? f.chance(0.85) : f.chance(0.3);
    const bool wrong = sum && f.chance(0.08);
    std::string line = sum ? withSum(cmd) : cmd;
    if (wrong) line.back() = line.back() == '0' ? '1' : '0';
    add(line);
    out.spin_checked = sum && !wrong && g.spins(cmd);
  } else if (kind < 55) {  // random bytes
    add(f.randomBytes(40));
  } else if (kind < 67) {  // a single-byte mutation of a (checksummed) command
    const std::string cmd = g.command(f);
    add(f.mutate(f.chance(0.5) ? withSum(cmd) : cmd));
  } else if (kind < 77) {  // a framing error somewhere in a command
    std::string cmd = withSum(g.command(f));
    const std::size_t at = static_cast<std::size_t>(f.uniform(0, static_cast<int>(cmd.size())));
    for (std::size_t i = 0; i <= cmd.size(); ++i) {
      if (i == at) out.items.push_back({static_cast<uint8_t>(f.uniform(0, 255)), true});
      if (i < cmd.size()) out.items.push_back({static_cast<uint8_t>(cmd[i]), false});
    }
  } else if (kind < 82) {  // over-long
    std::string s;
    for (int i = f.uniform(49, 120); i > 0; --i) s += static_cast<char>(f.uniform('a', 'z'));
    add(s);
  } else if (kind < 86) {  // a flood without a line end, then its end
    std::string s;
    const int n = f.uniform(100, 600);
    for (int i = 0; i < n; ++i) s += f.chance(0.5) ? "a\b" : std::string(1, static_cast<char>(f.uniform(0x20, 0x7E)));
    add(s);
  } else {  // empty line (read_run's keep-alive)
    add(strict ? "*00" : "");
  }
  add(f.terminator());
  return out;
}

void send(sim::Board& board, const std::vector<Item>& items) {
  std::string run;
  for (const Item& it : items) {
    if (!it.framing_error) {
      run += static_cast<char>(it.byte);
      continue;
    }
    board.sendText(run);
    run.clear();
    board.sendFramingError(it.byte);
  }
  board.sendText(run);
}

int countReset(const std::string& out) {
  int n = 0;
  for (std::size_t p = 0; (p = out.find("reset: ", p)) != std::string::npos; ++p) ++n;
  return n;
}

struct FuzzStats {
  int lines = 0;
  int rejected = 0;  // "error: " lines the firmware printed
  double simulated_s = 0, wall_s = 0;
};

// Runs the fuzz on one image; `abort_mid_line` starts a sweep or lift-off and breaks into it.
// Fails the calling test (fatally) on the first broken rule; `stats` holds what was done.
template <class Grammar>
void fuzzImage(const std::string& image, const std::string& prompt, uint64_t seed,
               const std::function<void(sim::Console&, Fuzzer&, bool strict)>& abort_mid_line,
               FuzzStats& stats) {
  const auto wall0 = std::chrono::steady_clock::now();
  sim::Board board(hil::imagePath(image));
  board.setAdcSource([](int ch) { return ch == 1 ? safety::batteryPinMv() : 2000.0; });
  const std::vector<uint8_t> start_eeprom = safety::calibratedEeprom();
  board.setEeprom(start_eeprom);
  sim::Console con(board, prompt);
  safety::PulseLog log(board);
  con.waitPrompt(10.0);
  Fuzzer f(seed);
  Grammar grammar;
  std::vector<uint8_t> eeprom = start_eeprom;
  const tc::test::Pattern changed_slot(R"((erased motor|stored .*of motor) (\d))");
  bool strict = false;
  const char* env_batches = std::getenv("THRUSTCAL_FUZZ_BATCHES");  // shorter runs while debugging
  const int batches = env_batches ? std::atoi(env_batches) : kBatches;
  for (int batch = 0; batch < batches; ++batch) {
    SCOPED_TRACE(fmt::format("{} batch {}", image, batch));
    const bool want_strict = (batch / 5) % 2 == 1;
    if (want_strict != strict) {
      const auto reply = con.command(want_strict ? "strict on" : "strict off");
      strict = want_strict;
      ASSERT_TRUE(contains(::testing::PrintToString(reply), strict ? "strict on" : "strict off"));
    }
    const std::size_t out_from = board.output().size();
    const double t_from = board.timeS();
    bool spin_sent = false;
    if (batch % 3 == 2) {
      abort_mid_line(con, f, strict);
      spin_sent = true;
      stats.lines += 2;
    }
    const bool burst = f.chance(0.5);
    for (int i = 0; i < kLinesPerBatch; ++i) {
      const FuzzLine line = makeLine(f, grammar, strict);
      spin_sent = spin_sent || line.spin_checked;
      const std::size_t mark = board.output().size();
      send(board, line.items);
      ++stats.lines;
      if (!burst) {  // line by line: wait for the answer, at most 0.1 s once the line is in
        board.runUntil([&] { return board.pendingInput() == 0; }, sim::secondsToCycles(5));
        // a prompt; or the echo and 20 ms of nothing more, read_run's whole answer to an empty
        // line (a keep-alive) and to any line while it streams rows
        if (sim::waitAnswer(con, mark, 0.02, 0.1) == sim::Answer::kPrompt) con.waitPrompt(0.01);
      }
    }
    sim::drainConsole(con, 0.1);
    // Motors at 1000 us when they should be: 1 s after the last input (read_run's failsafe
    // trips 500 ms after the last keep-alive it processed; replies still queued may delay that
    // one by a few hundred ms; gather_store: no sweep is running any more).
    board.runFor(1.0);
    for (int ch = 0; ch < 4; ++ch) {
      if (board.escPulseUs(ch) > 1000.6) {
        std::string dump = fmt::format("now {:.4f}\n", board.timeS());
        int shown = 0;
        for (auto it = log.pulses().rbegin(); it != log.pulses().rend() && shown < 12; ++it)
          if (it->channel == ch) {
            dump += fmt::format("  {:.1f} us ending {:.4f}\n", it->width_us, it->end_s);
            ++shown;
          }
        const auto& pin = board.escPin(ch);
        dump += fmt::format("pin high {} rise {:.4f} fall {:.4f} pulses {}\n", pin.high,
                            sim::cyclesToSeconds(pin.last_rise_cycle),
                            sim::cyclesToSeconds(pin.last_fall_cycle), pin.pulses);
        FAIL() << "ESC " << ch << " at " << board.escPulseUs(ch) << "\n" << dump << con.tail(30);
      }
    }
    while (con.unconsumed().find(con.prompt()) != std::string::npos) con.waitPrompt(0.01);
    // With strict on and no intact checksummed spin command, nothing spun at all.
    if (strict && !spin_sent) {
      ASSERT_LE(log.widestBetween(t_from, board.timeS()), 1000.6) << con.tail();
    }
    // The prompt still answers. (read_run: back to 50 Hz frames first, which the motors being
    // stopped allows; a batch's "rate 400" would otherwise make the rest 8 times slower to
    // simulate.)
    if (image == "read_run") con.command(withSum("rate 50"), 5.0);
    const auto status = con.command(withSum("status"), 5.0);
    ASSERT_TRUE(contains(::testing::PrintToString(status), "bytes never used")) << con.tail();
    // No reset.
    ASSERT_EQ(board.resets(), 0);
    ASSERT_EQ(countReset(board.output()), 1) << con.tail();
    // EEPROM: unchanged but for the slots a store or erase reported.
    const std::string batch_out = board.output().substr(out_from);
    std::set<int> allowed;
    for (const tc::test::Groups& m : changed_slot.allIn(batch_out)) allowed.insert(std::stoi(m[2]));
    const std::vector<uint8_t> now = board.eeprom();
    for (std::size_t a = 0; a < now.size(); ++a) {
      if (now[a] != eeprom[a]) {
        ASSERT_TRUE(allowed.count(static_cast<int>(a / 1024))) << "EEPROM byte " << a << " changed";
      }
    }
    eeprom = now;
    for (std::size_t p = out_from; (p = board.output().find("error: ", p)) != std::string::npos; ++p)
      ++stats.rejected;
  }
  stats.simulated_s = board.simulatedSeconds();
  stats.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
}

void report(const char* image, const FuzzStats& s) {
  std::printf("%s: %d lines fuzzed, %d error replies, %.0f s simulated in %.1f s\n", image, s.lines,
              s.rejected, s.simulated_s, s.wall_s);
  ::testing::Test::RecordProperty(std::string(image) + "_lines", s.lines);
  ::testing::Test::RecordProperty(std::string(image) + "_wall_s", fmt::format("{:.1f}", s.wall_s));
}

TEST(ConsoleFuzz, ReadRunSurvives10000FuzzedLines) {
  HIL_REQUIRE_IMAGE("read_run");
  FuzzStats s;
  fuzzImage<ReadRunGrammar>(
      "read_run", "rr> ", 0x5EEDF00D,
      [](sim::Console& con, Fuzzer& f, bool strict) {
        // a lift-off, kept alive a little, then a line whose first key aborts it
        const std::string cmd = fmt::format("liftoff {} 200 2000", f.uniform(50, 300));
        con.send(strict ? withSum(cmd) : cmd);
        for (int i = f.uniform(0, 4); i > 0; --i) {
          con.board().runFor(0.15);
          con.send("");
        }
        con.board().runFor(0.05);
        con.send(fmt::format("{}f {} {}", static_cast<char>(f.uniform('a', 'z')), f.uniform(0, 3),
                             f.uniform(100, 500)));
      },
      s);
  report("read_run", s);
  EXPECT_GE(s.lines, 10000);
}

TEST(ConsoleFuzz, GatherStoreSurvives10000FuzzedLines) {
  HIL_REQUIRE_IMAGE("gather_store");
  FuzzStats s;
  fuzzImage<GatherStoreGrammar>(
      "gather_store", "gs> ", 0xC0FFEE42,
      [](sim::Console& con, Fuzzer& f, bool strict) {
        // a sweep, then a line whose first key aborts it ("xerase")
        con.command("tare", 5.0);
        con.send(strict ? withSum("sweep") : "sweep");
        con.board().runFor(0.05 * f.uniform(1, 20));
        con.send(fmt::format("{}erase", static_cast<char>(f.uniform('a', 'z'))));
      },
      s);
  report("gather_store", s);
  EXPECT_GE(s.lines, 10000);
}

}  // namespace

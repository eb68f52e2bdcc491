// Generated blocks in the docs (bench/doc_blocks.hpp) and the drift comparison (bench/drift.hpp)
// on small JSON: what each kind renders, inline and block form, and the errors a writer meets.
#include <gtest/gtest.h>

#include <stdexcept>

#include "bench/doc_blocks.hpp"
#include "bench/drift.hpp"

namespace {

const nlohmann::json kResults = nlohmann::json::parse(R"({
  "fly": {"flash_bytes": 66714, "modes": {"force_v2": {"cpu_load_pct": 36.84}, "pwm": {"cpu_load_pct": 31.91},
                                          "force_thesis": {"cpu_load_pct": 49.87}}},
  "swap": {"runs": [
             {"rig": "seesaw", "mode": "force", "part": "kv1100_9x4.7", "seed": 1, "final_deg": 8.31, "change": -2.5},
             {"rig": "seesaw", "mode": "force", "part": "kv1100_9x4.7", "seed": 2, "final_deg": 8.52, "change": 1.5},
             {"rig": "gimbal", "mode": "force", "part": "kv1100_9x4.7", "seed": 1, "final_deg": 9.9, "change": 0.5},
             {"rig": "seesaw", "mode": "pwm", "part": "stock", "seed": 1, "final_deg": null, "change": 0}],
           "targets": [{"met": true}, {"met": false}, {"met": true}]},
  "tables": [{"title": "8. Swap dynamics: time constants", "header": ["motor", "tau"],
              "rows": [["stock", "78.9 ms"]], "notes": []}]
})");

std::string render(const std::string& doc) { return bench::withBlocks(doc, "doc.md", kResults); }

TEST(DocBlocks, InlineValueIsRewrittenInItsSentence) {
  EXPECT_EQ(render("flash <!-- generated: value fly.flash_bytes , -->1<!-- generated: end --> B."),
            "flash <!-- generated: value fly.flash_bytes , -->66,714<!-- generated: end --> B.");
}

TEST(DocBlocks, MarkersInACodeExampleAreShownNotRewritten) {
  const std::string fenced = "```\n<!-- generated: KIND ARG -->\n...\n<!-- generated: end -->\n```\n";
  EXPECT_EQ(render(fenced), fenced);
  const std::string span = "e.g. `<!-- generated: value fly.flash_bytes , -->1<!-- generated: end -->` and "
                           "<!-- generated: value fly.flash_bytes , -->1<!-- generated: end -->";
  EXPECT_EQ(render(span), "e.g. `<!-- generated: value fly.flash_bytes , -->1<!-- generated: end -->` and "
                          "<!-- generated: value fly.flash_bytes , -->66,714<!-- generated: end -->");
}

// A code span broken across lines closes on the next line: the marker after it is rewritten
// (fly.md once read a stale figure because the rule counted backticks on the marker's line
// only); one still open there is a code example; a new paragraph, list item or table row
// starts counting again.
TEST(DocBlocks, ACodeSpanBrokenAcrossLinesIsClosedWhereItCloses) {
  const std::string v = "<!-- generated: value fly.flash_bytes , -->1<!-- generated: end -->";
  const std::string filled = "<!-- generated: value fly.flash_bytes , -->66,714<!-- generated: end -->";
  EXPECT_EQ(render("With `dyn on` and `stream\n  on` the CPU is " + v + " %."),
            "With `dyn on` and `stream\n  on` the CPU is " + filled + " %.");
  const std::string open = "an example: `stream\n  " + v + "` here";
  EXPECT_EQ(render(open), open);
  EXPECT_EQ(render("a stray ` here\n\nnext paragraph " + v), "a stray ` here\n\nnext paragraph " + filled);
  EXPECT_EQ(render("- item with ` stray\n- next item " + v), "- item with ` stray\n- next item " + filled);
  EXPECT_EQ(render("| a ` | b |\n| " + v + " | c |"), "| a ` | b |\n| " + filled + " | c |");
}

TEST(DocBlocks, MinMaxRangeAndMaxabsOverAWildcard) {
  EXPECT_EQ(render("<!-- generated: range fly.modes.*.cpu_load_pct .1f -->?<!-- generated: end -->"),
            "<!-- generated: range fly.modes.*.cpu_load_pct .1f -->31.9-49.9<!-- generated: end -->");
  EXPECT_EQ(render("<!-- generated: range fly.modes{force_v2,pwm}.cpu_load_pct .1f --><!-- generated: end -->"),
            "<!-- generated: range fly.modes{force_v2,pwm}.cpu_load_pct .1f -->31.9-36.8<!-- generated: end -->");
  EXPECT_EQ(render("<!-- generated: max fly.modes.*.cpu_load_pct .1f --><!-- generated: end -->"),
            "<!-- generated: max fly.modes.*.cpu_load_pct .1f -->49.9<!-- generated: end -->");
  EXPECT_EQ(render("<!-- generated: maxabs swap.runs.*.change .1f --><!-- generated: end -->"),
            "<!-- generated: maxabs swap.runs.*.change .1f -->2.5<!-- generated: end -->");
}

TEST(DocBlocks, FilterSelectsArrayElementsEvenWithADotInAValue) {
  EXPECT_EQ(render("<!-- generated: range swap.runs[rig=seesaw,part=kv1100_9x4.7].final_deg .1f -->"
                   "<!-- generated: end -->"),
            "<!-- generated: range swap.runs[rig=seesaw,part=kv1100_9x4.7].final_deg .1f -->8.3-8.5"
            "<!-- generated: end -->");
  EXPECT_EQ(bench::numbersAt(kResults, "swap.runs[mode!=force].change"), (std::vector<double>{0}));
  EXPECT_EQ(render("<!-- generated: range swap.runs.*.change +.1f --><!-- generated: end -->"),
            "<!-- generated: range swap.runs.*.change +.1f -->-2.5..+1.5<!-- generated: end -->");
  // a number matched as text; a null (a figure the run could not measure) is skipped
  EXPECT_EQ(bench::numbersAt(kResults, "swap.runs[seed=1].final_deg"), (std::vector<double>{8.31, 9.9}));
}

TEST(DocBlocks, MetCountsTheTargetsMet) {
  EXPECT_EQ(render("<!-- generated: met swap.targets -->x<!-- generated: end -->"),
            "<!-- generated: met swap.targets -->2 of 3<!-- generated: end -->");
}

TEST(DocBlocks, BlockFormRendersATableBetweenItsMarkerLines) {
  const std::string doc = "before\n<!-- generated: table \"8. Swap dynamics\" -->\nstale\n<!-- generated: end -->\nafter\n";
  EXPECT_EQ(render(doc),
            "before\n<!-- generated: table \"8. Swap dynamics\" -->\n| motor | tau |\n|---|---:|\n| stock | 78.9 ms |\n"
            "<!-- generated: end -->\nafter\n");
  EXPECT_EQ(render(render(doc)), render(doc));  // rendering again changes nothing
}

TEST(DocBlocks, ErrorsNameFileLineAndWhat) {
  const auto error = [](const std::string& doc) {
    try {
      render(doc);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("a\n<!-- generated: value fly.nothing -->1<!-- generated: end -->"),
            "doc.md:2: the results JSON has no \"nothing\" (in fly.nothing): run tools/results.sh, or fix the block's "
            "path");
  EXPECT_EQ(error("<!-- generated: value fly.modes.*.cpu_load_pct -->1<!-- generated: end -->"),
            "doc.md:1: value fly.modes.*.cpu_load_pct matches 3 numbers: use min, max or range");
  EXPECT_EQ(error("<!-- generated: frobnicate x -->1<!-- generated: end -->"),
            "doc.md:1: unknown kind \"frobnicate\" (measured, table, value, min, max, maxabs, range, met)");
  EXPECT_EQ(error("x\n\n<!-- generated: value fly.flash_bytes -->1"),
            "doc.md:3: no \"<!-- generated: end -->\" after this block");
  EXPECT_EQ(error("<!-- generated: table \"9. Nothing\" -->\n<!-- generated: end -->\n"),
            "doc.md:1: no bench table's title starts with \"9. Nothing\"");
  EXPECT_EQ(error("<!-- generated: table \"8. Swap dynamics\" -->x<!-- generated: end -->"),
            "doc.md:1: \"table\" gives several lines: put its markers on lines of their own");
}

TEST(Drift, AFigurePastItsToleranceIsCountedAndOneWithinIsNot) {
  const nlohmann::json docs = {{"fly", {{"flash_bytes", 66714}, {"sram_static_bytes", 3023}}}};
  nlohmann::json now = {{"fly", {{"flash_bytes", 66714 + 300}, {"sram_static_bytes", 3023 + 16}}}};
  bench::DriftResult r = bench::compareDrift(docs, now, bench::driftFigures(now));
  EXPECT_EQ(r.compared, 2);
  EXPECT_EQ(r.drifted, 0);  // 300 B is within 0.5 % of 66,714 B; 16 B of SRAM within 16 B
  now["fly"]["flash_bytes"] = 66714 + 400;
  now["fly"]["sram_static_bytes"] = 3023 - 17;
  r = bench::compareDrift(docs, now, bench::driftFigures(now));
  EXPECT_EQ(r.drifted, 2);
  EXPECT_EQ(r.missing, 0);
}

TEST(Drift, SwapRunsAreComparedWithTheSameRunOfTheDocs) {
  const auto run = [](double rise_s) {
    return nlohmann::json{{"rig", "gimbal"}, {"mode", "force"}, {"part", "kv900_11x4.7"}, {"gains", "pd"},
                          {"axis", "roll"},  {"seed", 1},       {"rise_s", rise_s}};
  };
  nlohmann::json other = run(0.3);
  other["seed"] = 2;  // another IMU unit: not the run compared
  const nlohmann::json docs = {{"swap", {{"runs", {other, run(0.215)}}}}};
  const nlohmann::json now = {{"swap", {{"runs", {run(0.2165)}}}}};
  const std::vector<bench::DriftFigure> figures = bench::driftFigures(now);
  ASSERT_EQ(figures.size(), 1u);
  EXPECT_EQ(figures[0].path, "swap.runs[rig=gimbal,mode=force,part=kv900_11x4.7,gains=pd,axis=roll,seed=1].rise_s");
  EXPECT_EQ(bench::compareDrift(docs, now, figures).drifted, 0);  // 1.5 ms: within 2 ms
  EXPECT_EQ(bench::compareDrift(docs, {{"swap", {{"runs", {run(0.225)}}}}}, figures).drifted, 1);
  EXPECT_EQ(bench::compareDrift({{"swap", {{"runs", {other}}}}}, now, figures).missing, 1);
}

TEST(Drift, TwiRowsAndDlpfSettingsAreComparedRowByRow) {
  const auto twi_row = [](uint64_t twps, uint64_t polled) {
    return nlohmann::json{{"scl_hz", 100000}, {"twps", twps},          {"bytes", 14},
                          {"bus_cycles_model", 24960}, {"polled_cycles", polled}, {"interrupt_cycles", 26899}};
  };
  const auto dlpf = [](double gyro_delay_ms) {
    return nlohmann::json{{"cfg", 5},
                          {"gyro", {{"delay_ms", gyro_delay_ms}, {"noise_rms", 0.022}, {"bandwidth_hz", 11.8}}},
                          {"accel", {{"delay_ms", 13.82}, {"noise_rms", 1.5}}}};  // no -3 dB: unfiltered
  };
  const nlohmann::json docs = {{"twi", {{"rows", {twi_row(0, 26756), twi_row(1, 26749)}}}},
                               {"imu", {{"dlpf", {dlpf(13.41)}}}}};
  nlohmann::json now = {{"twi", {{"rows", {twi_row(1, 26749 + 200)}}}}, {"imu", {{"dlpf", {dlpf(13.414)}}}}};
  const std::vector<bench::DriftFigure> figures = bench::driftFigures(now);
  ASSERT_EQ(figures.size(), 3u + 5u);  // bus, polled, interrupt; gyro delay, noise, -3 dB; accel delay, noise
  EXPECT_EQ(figures[1].path, "twi.rows[scl_hz=100000,twps=1,bytes=14].polled_cycles");
  bench::DriftResult r = bench::compareDrift(docs, now, figures);
  EXPECT_EQ(r.drifted, 0);  // 200 cycles within 1 % of 26,749; 0.004 ms within 0.005 ms
  EXPECT_EQ(r.missing, 0);
  now["twi"]["rows"][0]["bus_cycles_model"] = 24961;  // the bus time is exact
  now["imu"]["dlpf"][0]["gyro"]["delay_ms"] = 13.42;
  r = bench::compareDrift(docs, now, figures);
  EXPECT_EQ(r.drifted, 2);
}

}  // namespace

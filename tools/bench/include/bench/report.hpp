// docs/results.md and README's "Measured" table, written from the JSON of
// `thrustcal bench all --json`: the docs carry the bench's own figures, so they cannot drift
// from what was measured. tools/results.sh re-runs the bench and rewrites both (and every other
// generated block, bench/doc_blocks.hpp); the ctest Checks.ResultsDocsAreTheBenchJson fails when
// the committed docs and docs/results.json differ.
#pragma once
#include <string>

#include <nlohmann/json.hpp>

namespace bench {

// The whole of docs/results.md: every table the bench printed (its "tables" array), targets
// first. Throws std::runtime_error naming what is missing from the JSON.
std::string resultsMarkdown(const nlohmann::json& bench);

// README's "Measured" table (markdown), each figure read from the JSON: the block
// `<!-- generated: measured -->` (bench/doc_blocks.hpp).
std::string measuredTable(const nlohmann::json& bench);

}  // namespace bench

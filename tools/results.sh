#!/usr/bin/env bash
# Measures again and rewrites the figures in the docs: builds the firmware images and the
# thrustcal tool, runs every benchmark (`thrustcal bench all --json docs/results.json`: simavr
# scenarios and the swap experiment's full run, minutes), then writes docs/results.md and every
# generated block of README.md and docs/*.md from that JSON (`thrustcal bench report`; docs/
# testing.md, "Generated figures"). Commit them together: ctest's Checks.ResultsDocsAreTheBenchJson
# fails when the docs and docs/results.json disagree, Results.CheapFiguresHaveNotDrifted when the
# code no longer measures what docs/results.json says.
#   tools/results.sh        JOBS=N for the build and the swap's flights
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
cd "$THRUSTCAL_ROOT"

ensure_packages "${THRUSTCAL_DEMO_PACKAGES[@]}"
build_avr
build_plain thrustcal
tc=build/host/tools/thrustcal/thrustcal

say "running every benchmark (simulated; minutes)"
raw=$(mktemp)
trap 'rm -f "$raw"' EXIT
"$tc" bench all --jobs "$JOBS" --json "$raw" >/dev/null
# Which source the figures are from: the commit, and whether the tree had changes on top.
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=false
git diff --quiet HEAD -- 2>/dev/null || dirty=true
jq --arg commit "$commit" --argjson dirty "$dirty" '. + {source: {commit: $commit, dirty: $dirty}}' \
  "$raw" > docs/results.json

say "writing docs/results.md and the generated figures of README.md and docs/*.md"
"$tc" bench report --from docs/results.json --results docs/results.md --docs README.md docs/*.md
"$tc" bench report --from docs/results.json --results docs/results.md --docs README.md docs/*.md --check

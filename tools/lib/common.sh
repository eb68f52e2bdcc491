# Shared by tools/demo.sh and tools/test.sh: install what is missing, build both trees.
# Sourced, not run.

THRUSTCAL_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
JOBS="${JOBS:-$(nproc 2>/dev/null || echo 2)}"

# Debian packages the project needs (build, firmware, simulator, lab, plots, coverage).
THRUSTCAL_PACKAGES=(
  cmake g++ make pkg-config
  gcc-avr binutils-avr avr-libc avrdude arduino-core-avr
  simavr libsimavr-dev libelf-dev
  googletest libgtest-dev libgmock-dev
  libeigen3-dev libcli11-dev libmuparser-dev nlohmann-json3-dev libfmt-dev
  gnuplot-nox gcovr jq
)
# What tools/fuzz.sh adds (libFuzzer ships with Debian's clang runtime).
THRUSTCAL_FUZZ_PACKAGES=(clang libclang-rt-14-dev)

say() { printf '\033[1m==> %s\033[0m\n' "$*" >&2; }
die() { printf 'error: %s\n' "$*" >&2; exit 1; }

# ensure_packages [PACKAGE...]: installs the given packages (default THRUSTCAL_PACKAGES)
# that are missing.
ensure_packages() {
  local missing=() p
  local wanted=("$@")
  [ ${#wanted[@]} -eq 0 ] && wanted=("${THRUSTCAL_PACKAGES[@]}")
  for p in "${wanted[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  say "installing missing Debian packages: ${missing[*]}"
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || die "need root or sudo to install: ${missing[*]}"
    sudo="sudo"
  fi
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq \
    || die "apt-get update failed; install by hand: apt-get install ${missing[*]}"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null \
    || die "apt-get install failed for: ${missing[*]}"
}

# build_avr: firmware images into build/avr (prints avr-size for each image).
build_avr() {
  say "configuring the AVR tree (build/avr)"
  cmake --preset avr >/dev/null
  say "building firmware images"
  cmake --build --preset avr -j "$JOBS"
}

# build_host [extra cmake args]: core, fake HAL, tests and the thrustcal tool into build/host.
build_host() {
  say "configuring the host tree (build/host)"
  cmake --preset host "$@" >/dev/null
  say "building host tools and tests"
  cmake --build --preset host -j "$JOBS"
}

print_firmware_sizes() {
  local img
  for img in gather_store read_run; do
    local elf="$THRUSTCAL_ROOT/build/avr/firmware/$img/$img.elf"
    [ -f "$elf" ] || die "missing $elf"
    printf '%-13s ' "$img"
    avr-size --format=avr --mcu=atmega2560 "$elf" | awk '/^Program:/{p=$2" B flash "$4" Full)"} /^Data:/{d=$2" B static SRAM "$4" Full)"} END{print p", "d}'
  done
}

# Shared by tools/demo.sh, tools/test.sh, tools/results.sh and tools/fuzz.sh: install what is
# missing, configure and build the trees each needs.
# Sourced, not run.

THRUSTCAL_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
JOBS="${JOBS:-$(nproc 2>/dev/null || echo 2)}"

# Debian packages: what tools/demo.sh needs (build, firmware, simulator, lab, plots), and what
# the tests add (GoogleTest, avrdude for the board tests, gcovr for coverage).
THRUSTCAL_DEMO_PACKAGES=(
  cmake g++ make pkg-config
  gcc-avr binutils-avr avr-libc arduino-core-avr
  simavr libsimavr-dev libelf-dev
  libeigen3-dev libcli11-dev libmuparser-dev nlohmann-json3-dev libfmt-dev
  gnuplot-nox jq
)
THRUSTCAL_TEST_PACKAGES=(googletest libgtest-dev libgmock-dev avrdude gcovr python3)
THRUSTCAL_PACKAGES=("${THRUSTCAL_DEMO_PACKAGES[@]}" "${THRUSTCAL_TEST_PACKAGES[@]}")
# What tools/fuzz.sh adds (libFuzzer ships with Debian's clang runtime).
THRUSTCAL_FUZZ_PACKAGES=(clang libclang-rt-14-dev)

# say MESSAGE: a step's heading, with the seconds since the script started (bash's SECONDS), so
# a log shows where a run's time went.
say() { printf '\033[1m==> [%4d s] %s\033[0m\n' "$SECONDS" "$*" >&2; }
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

# build_avr [TARGET...]: firmware images into build/avr (all of them by default).
build_avr() {
  say "configuring the AVR tree (build/avr)"
  cmake --preset avr >/dev/null
  say "building firmware images${1:+: $*}"
  if [ $# -eq 0 ]; then
    cmake --build --preset avr -j "$JOBS"
  else
    cmake --build --preset avr -j "$JOBS" --target "$@"
  fi
}

# The two host trees, each configured with every flag that decides what its binaries are, so a
# cache left by an earlier configure cannot change them (docs/testing.md, "Two host trees"):
#   plain   build/host     tools/demo.sh, tools/results.sh: optimised, no instrumentation
#   checked build/checked  tools/test.sh: core/ line coverage, ASan + UBSan on every object
THRUSTCAL_PLAIN_FLAGS=(-DTHRUSTCAL_TREE=plain -DCMAKE_BUILD_TYPE=RelWithDebInfo
  "-DTHRUSTCAL_HOST_OPT=-O2 -g1" -DTHRUSTCAL_SANITIZE=OFF -DTHRUSTCAL_COVERAGE=OFF -DTHRUSTCAL_FUZZ=OFF)
THRUSTCAL_CHECKED_FLAGS=(-DTHRUSTCAL_TREE=checked -DCMAKE_BUILD_TYPE=RelWithDebInfo
  -DTHRUSTCAL_SANITIZE=ON -DTHRUSTCAL_UBSAN_SKIP=alignment,null,pointer-overflow,object-size,vptr
  -DTHRUSTCAL_ASAN_SCOPE=OFF "-DTHRUSTCAL_SANITIZE_OPT=-Og -g1"
  -DTHRUSTCAL_COVERAGE=ON -DTHRUSTCAL_FUZZ=OFF -DTHRUSTCAL_TESTS=ON)

# cache_value DIR NAME: NAME's value in DIR's CMakeCache.txt (empty when absent).
cache_value() {
  sed -n "s/^$2:[A-Z]*=//p" "$1/CMakeCache.txt" 2>/dev/null | head -n 1
}

# check_tree_cache DIR FLAG...: dies unless DIR's cache holds each -DNAME=VALUE given, and (for
# the plain tree) no instrumentation slipped in through CMAKE_*_FLAGS (e.g. CXXFLAGS at the first
# configure).
check_tree_cache() {
  local dir=$1 flag name want got v
  shift
  for flag in "$@"; do
    flag=${flag#-D}
    name=${flag%%=*}
    want=${flag#*=}
    got=$(cache_value "$dir" "$name")
    [ "$got" = "$want" ] || die "$dir was configured with $name=$got, but this script builds it with \
$name=$want; its CMake cache disagrees with the flags passed. Remove $dir (rm -rf $dir) and run again."
  done
  if [ "$(cache_value "$dir" THRUSTCAL_TREE)" = plain ]; then
    for name in CMAKE_CXX_FLAGS CMAKE_C_FLAGS CMAKE_EXE_LINKER_FLAGS; do
      v=$(cache_value "$dir" "$name")
      case "$v" in
        *-fsanitize*|*--coverage*|*-fprofile-arcs*)
          die "$dir is the plain tree, but its $name holds instrumentation ($v); unset CFLAGS, CXXFLAGS \
and LDFLAGS, remove $dir and run again" ;;
      esac
    done
  fi
}

# configure_host_tree PRESET [FLAG...]: configures PRESET's tree with the flags, then checks its
# cache holds them.
configure_host_tree() {
  local preset=$1 dir
  shift
  dir="$THRUSTCAL_ROOT/build/$([ "$preset" = host ] && echo host || echo "$preset")"
  say "configuring the host tree ($preset: ${dir#"$THRUSTCAL_ROOT"/})"
  cmake --preset "$preset" "$@" >/dev/null
  check_tree_cache "$dir" "$@"
}

# build_plain [TARGET...]: the plain tree (build/host), only the targets named (tools/demo.sh
# and tools/results.sh need `thrustcal` alone; tests are not configured: no GoogleTest needed).
build_plain() {
  configure_host_tree host "${THRUSTCAL_PLAIN_FLAGS[@]}" -DTHRUSTCAL_TESTS=OFF
  if [ $# -eq 0 ]; then
    say "building the plain host tree (build/host)"
    cmake --build --preset host -j "$JOBS"
  else
    say "building $* (build/host)"
    cmake --build --preset host -j "$JOBS" --target "$@"
  fi
}

# build_checked: the checked tree (build/checked), every test and tool.
build_checked() {
  configure_host_tree checked "${THRUSTCAL_CHECKED_FLAGS[@]}"
  say "building host tools and tests, coverage + ASan + UBSan (build/checked)"
  cmake --build --preset checked -j "$JOBS"
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

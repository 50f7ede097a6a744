#!/usr/bin/env bash
# Installs the Debian packages auger needs, skipping those already installed.
# Idempotent; runs apt-get only when something is missing. Called by `make deps`
# (and so by `make test` / `make demo`). Needs root or sudo when it has work to do.
set -euo pipefail

packages=(
  # toolchains and build
  build-essential cmake ninja-build pkg-config python3
  # the project's Python venv (scripts/make-venv.sh): `auger import`, the Python tests, the DDS
  # tests' independent participant
  python3-venv
  # firmware
  gcc-avr binutils-avr avr-libc avrdude
  # firmware-in-the-loop simulation
  simavr libsimavr-dev libelf-dev arduino-core-avr
  # host; augerd's ROS 2 interface: Eclipse Cyclone DDS and its IDL compiler idlc
  libeigen3-dev libtomlplusplus-dev nlohmann-json3-dev libserial-dev catch2 cyclonedds-dev cyclonedds-tools
  # the DDS Security keystore of that interface (auger ros2-keys runs the openssl program)
  openssl
  # fuzzing (libFuzzer) and sanitizers
  clang libclang-rt-14-dev
  # benchmarks (instruction counts)
  valgrind
  # workbench reports (plots), field tools (terminal UI) and their tmux-driven tests
  gnuplot-nox libncurses-dev tmux
  # auger report's interactive time plots (inlined into the page) and the browser that tests the page
  libjs-dygraphs chromium
)
# The board (aarch64) build: a cross compiler and qemu-user to run its binaries in the tests.
# On an arm64 machine the native compiler builds for the board and runs the binaries itself.
if [[ $(dpkg --print-architecture) != arm64 ]]; then
  packages+=(g++-aarch64-linux-gnu qemu-user)
fi

# ---- board (issue 7, docs/board.md) ----
# `scripts/install-deps.sh board` (make board): only what building augerd, auger and
# auger-module for the board needs, so that the board itself (or a workstation that only
# builds for it) does not get the simulator, fuzzer and benchmark tools; plus avrdude, to
# flash the modules from the board. Catch2 because the top-level CMakeLists looks for it.
# A library that is not header-only and that host/ links (ncurses, if `auger` links it: a
# host/ CMakeLists asking for Curses) is then needed for arm64: natively libncurses-dev, on
# another architecture its arm64 package through Debian multiarch (dpkg --add-architecture
# arm64, only then).
multiarch=()
if [[ ${1:-} == board ]]; then
  packages=(build-essential cmake ninja-build pkg-config libeigen3-dev libtomlplusplus-dev nlohmann-json3-dev catch2 avrdude)
  [[ $(dpkg --print-architecture) == arm64 ]] || packages+=(g++-aarch64-linux-gnu qemu-user)
  # `make board ROS2=1`: augerd with its ROS 2 interface, against Cyclone DDS for arm64; idlc
  # (cyclonedds-tools) runs on the build machine.
  if [[ ${ROS2:-0} == 1 ]]; then
    packages+=(cyclonedds-tools)
    if [[ $(dpkg --print-architecture) == arm64 ]]; then packages+=(cyclonedds-dev); else multiarch+=(cyclonedds-dev:arm64); fi
  fi
fi
if grep -qsi 'curses' "$(dirname "$0")"/../host/*/CMakeLists.txt "$(dirname "$0")"/../host/CMakeLists.txt; then
  if [[ $(dpkg --print-architecture) == arm64 ]]; then
    packages+=(libncurses-dev)
  else
    multiarch+=(libncurses-dev:arm64)
  fi
fi
packages+=("${multiarch[@]}")

missing=()
native=$(dpkg --print-architecture)
for p in "${packages[@]}"; do
  # A name without :arch is the build machine's (or an Architecture: all) package; with arm64
  # multiarch, dpkg-query also lists the arm64 one of the same name.
  want_arch=${p#*:}
  [[ $p == *:* ]] || want_arch=$native
  dpkg-query -W -f='${Architecture} ${Status}\n' "$p" 2>/dev/null |
    grep -Eq "^($want_arch|all) install ok installed\$" || missing+=("$p")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
if [[ ${#multiarch[@]} -gt 0 ]] && ! dpkg --print-foreign-architectures | grep -qx arm64; then
  echo "install-deps: adding the arm64 architecture (multiarch) for ${multiarch[*]}"
  "${sudo_cmd[@]}" dpkg --add-architecture arm64
fi
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"

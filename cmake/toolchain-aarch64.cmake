# The robot's host computer, an A64-OLinuXino (Allwinner A64: four Cortex-A53 at 1.152 GHz,
# aarch64, Debian 12), built from an x86-64 Debian 12 workstation with Debian's cross compiler
# (g++-aarch64-linux-gnu). `make board` uses this file only when the build machine is not
# aarch64; on the board itself the same flags come from AUGER_BOARD_CXX_FLAGS in the Makefile.
#
# No sysroot: Debian's cross gcc already searches /usr/aarch64-linux-gnu/include (the arm64
# libc and libstdc++) before /usr/include, where the header-only Eigen and toml++ of the build
# machine live; those headers are the same on every architecture, so no arm64 -dev package is
# needed for them. A library that is not header-only (ncurses, if `auger` links it) comes from
# Debian multiarch: its arm64 -dev package puts it in /usr/lib/aarch64-linux-gnu, which
# CMAKE_LIBRARY_ARCHITECTURE below makes find_library search (scripts/install-deps.sh
# installs it when a host/ CMakeLists asks for Curses).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)

# Tune and select instructions for the A53 (in-order, dual-issue); the binary still runs on any
# ARMv8-A core, and under qemu-aarch64 in the tests. No fused multiply-add contraction: GCC
# contracts a * b + c into one FMADD by default in C++ on aarch64 (x86-64 without -mfma has no
# such instruction), which rounds once instead of twice; the host core's tests, written and run
# on x86, then fail on aarch64 where they compare for exact zero (tests/host test_effects.cpp,
# Coulomb friction holding the robot still: found by running them under qemu, docs/board.md).
# Same arithmetic as the workstation's, so what is tested there is what runs on the robot.
set(AUGER_BOARD_FLAGS "-mcpu=cortex-a53 -ffp-contract=off")
set(CMAKE_C_FLAGS_INIT "${AUGER_BOARD_FLAGS}")
set(CMAKE_CXX_FLAGS_INIT "${AUGER_BOARD_FLAGS}")

# The arm64 libraries are under /usr/aarch64-linux-gnu (libc, libstdc++) and
# /usr/lib/aarch64-linux-gnu (multiarch -dev packages); the build machine's own libraries must
# never be linked. Headers and CMake package files (Eigen3, Catch2: header-only) come from the
# build machine's /usr.
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu)
set(CMAKE_IGNORE_PATH /usr/lib/x86_64-linux-gnu /lib/x86_64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)

# Test programs of this build run under qemu-user (no binfmt registration needed).
find_program(AUGER_QEMU_AARCH64 qemu-aarch64)
if(AUGER_QEMU_AARCH64)
  # The cross ld.so with its own libc, not the arm64 multiarch one its cache would name
  # (tests/board/qemu_augerd.sh says why).
  set(CMAKE_CROSSCOMPILING_EMULATOR ${AUGER_QEMU_AARCH64} -L /usr/aarch64-linux-gnu
      -E LD_LIBRARY_PATH=/usr/aarch64-linux-gnu/lib)
endif()

# pkg-config (pkg_check_modules) must describe the arm64 libraries, not the build machine's.
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
set(ENV{PKG_CONFIG_PATH} "")

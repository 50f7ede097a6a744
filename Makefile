# auger: the front door. `make test` and `make demo` install what is missing, build and run.
# Targets:
#   make test        everything CI runs: deps, builds, unit + protocol tests (also under
#                    ASan+UBSan), header checks with avr-gcc and g++, a bounded fuzz run
#   make test-full   longer suites (see docs/benchmarks.md)
#   make demo        the simulated robot on sand driven by augerd (scripts/demo.sh)
#   make firmware    build the motor-module image (firmware/build/auger-module.elf, .hex)
#   make flash PORT=/dev/ttyUSB0 [ID=n]   flash a module through Optiboot, set its id
#   make deps        install missing Debian packages (scripts/install-deps.sh)
#   make host        configure and build the host, simulator and tests (Release, build/)
#   make venv        the Python environment build/venv (python/requirements.txt; auger import, the
#                    Python tests, the DDS tests' independent ROS 2 participant)
#   make asan        the unit and protocol tests with ASan+UBSan (build-asan/; make asan-full:
#                    those of the workbench and the simulated robot too)
#   make fuzz        run the protocol parser fuzzer (FUZZ_RUNS, default unbounded: Ctrl-C)
#   make bench-protocol   XOR byte vs CRC-16 corruption figures (docs/protocol.md)
#   make bench-firmware   firmware cycles, edge rates, CPU load, simulation speed (docs/benchmarks.md)
#   make bench-host       instructions and time per host controller step (callgrind)
#   make bench-online     the online estimator's cost per cycle (x86, aarch64 under qemu) and its
#                         change detector's delay / false-alarm curve (docs/benchmarks.md)
#   make bench-online-fil the same detector on hours of firmware-in-the-loop logs (~5 min)
#   make bench-robot      speed of the whole simulated robot in lock-step
#   make bench-ros2       what augerd's ROS 2 interface costs its 100 Hz loop, under load
#   make bench-explain    auger explain on 240 s and 10 min logs (wall and CPU seconds)
#   make bench-import     auger import of 10 min and 1 h bags (wall seconds, peak memory)
# The robot's board (A64-OLinuXino, aarch64; docs/board.md):
#   make board       augerd, auger, auger-module for aarch64 (cross on x86, native on aarch64),
#                    in build-aarch64/ (BOARD_BUILD); ROS2=1: with augerd's ROS 2 interface
#   make board-test  the unit tests of the board build under qemu-user (or natively)
#   make install / uninstall   [DESTDIR=] [PREFIX=/usr/local] [SYSCONFDIR=/etc] [INSTALL_FROM=build-aarch64]
#   make flash-all PORTS="P0 P1 P2 P3"   flash the four modules, ids 0..3 in that order, check them
#   make bench-board      the controller step's aarch64 instructions (qemu) and an A53 estimate
SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
JOBS ?= $(shell nproc)
BUILD ?= build
ASAN_BUILD ?= build-asan
FUZZ_BUILD ?= build-fuzz
CMAKE_GENERATOR ?= Ninja

AVR_CFLAGS := -mmcu=atmega328p -DF_CPU=16000000UL -std=c99 -Os -Wall -Wextra -Werror -pedantic
HOST_WARN := -Wall -Wextra -Werror -pedantic

.PHONY: all deps firmware flash host asan asan-full check-protocol fuzz fuzz-smoke test test-full demo \
        bench-protocol bench-firmware bench-host bench-online bench-online-fil bench-robot bench-ros2 bench-explain bench-import pid-units \
        clean venv \
        board board-deps board-test install uninstall flash-all bench-board

all: host

deps:
	@bash scripts/install-deps.sh

firmware: deps
	$(MAKE) -C firmware

PORT ?= /dev/ttyUSB0
ID ?=
flash: firmware
	cmake -S . -B $(BUILD) -G $(CMAKE_GENERATOR) -DCMAKE_BUILD_TYPE=Release -DAUGER_SANITIZE=OFF -DAUGER_WITH_SIM=ON
	cmake --build $(BUILD) -j $(JOBS) --target auger-module
	AUGER_MODULE=$(BUILD)/host/tools/auger-module \
	  scripts/flash-module.sh $(PORT) firmware/build/auger-module.hex $(ID)

# One Python environment for the project (python/requirements.txt; pip runs only when that
# file changed): `auger import` runs in it, the Python tests, and the DDS tests' independent ROS 2
# participant.
venv: deps
	scripts/make-venv.sh $(abspath $(BUILD))/venv

host: deps firmware
	cmake -S . -B $(BUILD) -G $(CMAKE_GENERATOR) -DCMAKE_BUILD_TYPE=Release -DAUGER_SANITIZE=OFF -DAUGER_WITH_SIM=ON
	cmake --build $(BUILD) -j $(JOBS)

# Only the programs of the `unit` tests are built here (a unit test missing from these lists
# makes `ctest -L unit` below fail, not pass). make test: the code that runs on the modules and
# the robot (protocol, firmware logic, host core, augerd and its ROS 2 interface, the operator's
# commands) and the simulated motor models.
ASAN_TARGETS := test_protocol test_firmware_logic test_host_core test_sim_models \
                test_daemon_unit test_operator_unit test_ros2_unit
# make test-full adds the tests labelled sanitize_full: the workbench engine (a pose_time_offset
# fitted on augerd's log and loaded into augerd among them), the simulated robot and its log
# generator. Building the workbench engine and the robot simulator under the sanitizers was a
# third of this build's time; in make test they run in the Release build only.
ASAN_FULL_TARGETS := test_workbench_engine test_pose_time test_robot_unit test_sim_log
asan: deps firmware
	cmake -S . -B $(ASAN_BUILD) -G $(CMAKE_GENERATOR) -DCMAKE_BUILD_TYPE=Debug \
	  -DAUGER_SANITIZE=ON -DAUGER_WITH_SIM=ON
	cmake --build $(ASAN_BUILD) -j $(JOBS) --target $(ASAN_TARGETS)
asan-full: asan
	cmake --build $(ASAN_BUILD) -j $(JOBS) --target $(ASAN_FULL_TARGETS)

# shared/protocol.h and .c must compile cleanly for the module (C99, avr-gcc -Os) and the
# host (C99 and C++17).
check-protocol: deps
	@mkdir -p $(BUILD)/check
	avr-gcc $(AVR_CFLAGS) -c shared/protocol.c -o $(BUILD)/check/protocol.avr.o
	gcc -std=c99 $(HOST_WARN) -c shared/protocol.c -o $(BUILD)/check/protocol.host.o
	printf '#include "protocol.h"\nint main() { proto_parser_t p; proto_parser_init(&p); return p.n; }\n' \
	  | g++ -std=c++17 $(HOST_WARN) -Ishared -x c++ - -x none -o $(BUILD)/check/protocol_cxx \
	    $(BUILD)/check/protocol.host.o
	@echo "check-protocol: protocol.h/.c compile with avr-gcc (C99), gcc (C99) and g++ (C++17)"

$(FUZZ_BUILD)/fuzz_parser: shared/protocol.c shared/protocol.h tests/fuzz/fuzz_parser.c | deps
	@mkdir -p $(FUZZ_BUILD)
	clang -std=c99 -g -O1 -Wall -Wextra -Werror -fsanitize=fuzzer,address,undefined \
	  -fno-sanitize-recover=all -Ishared shared/protocol.c tests/fuzz/fuzz_parser.c -o $@

$(FUZZ_BUILD)/corpus: tests/protocol/gen_vectors.py
	python3 tests/protocol/gen_vectors.py --corpus $@
	@touch $@

FUZZ_RUNS ?= -1
fuzz: $(FUZZ_BUILD)/fuzz_parser $(FUZZ_BUILD)/corpus
	@mkdir -p $(FUZZ_BUILD)/work
	$(FUZZ_BUILD)/fuzz_parser -runs=$(FUZZ_RUNS) -seed=1 -max_len=512 \
	  $(FUZZ_BUILD)/work $(FUZZ_BUILD)/corpus

# The bounded run inside `make test`: fixed seed, fixed number of inputs.
fuzz-smoke: $(FUZZ_BUILD)/fuzz_parser $(FUZZ_BUILD)/corpus
	@rm -rf $(FUZZ_BUILD)/smoke && mkdir -p $(FUZZ_BUILD)/smoke
	$(FUZZ_BUILD)/fuzz_parser -runs=300000 -seed=1 -max_len=512 -print_final_stats=1 \
	  $(FUZZ_BUILD)/smoke $(FUZZ_BUILD)/corpus 2>&1 | tail -n 3

# Two tests at a time. The real-time tests (RESOURCE_LOCK realtime: a simulated robot or modules
# against augerd on the wall clock, mostly waiting: 1-2 s of CPU in 15 s) run one at a time beside
# the others; those marked RUN_SERIAL (the load test's stop latency, the board's binaries under
# qemu, the workbench suites that run two jobs themselves) run alone.
# The venv's install (pip, mostly waiting on the network) runs beside the host's build; the
# sanitizer, fuzzer and board builds run two at a time, so that one's configure and final links
# overlap the other's compiles.
test: deps check-protocol
	$(MAKE) -j 2 host venv
	$(MAKE) board-deps
	$(MAKE) -j 2 asan fuzz-smoke board BOARD_TARGETS="$(BOARD_RUNTIME_TARGETS)"
	cd $(ASAN_BUILD) && ctest --output-on-failure -L unit -LE sanitize_full -j $(JOBS)
	cd $(BUILD) && AUGER_BOARD_BUILD=$(abspath $(BOARD_BUILD)) AUGER_BOARD_CLI=host \
	  ctest --output-on-failure -LE long -j $(JOBS)

# Longer suites (docs/benchmarks.md has their times): the unit tests labelled sanitize_full
# under ASan+UBSan, board_qemu again with the board's own `auger`, the tests labelled `long` (flash-all into
# four simulated modules; auger report --explain in headless Chromium with a screenshot; augerd's
# online estimate against the offline fit of its own log), the
# parser fuzzer for 5 million inputs, the sand diagonal with the firmware in the loop across the
# blocking thresholds, augerd's load test for a minute (docs/daemon.md "Limits and abuse"), the
# hidden-effect suite with 10 seeds per effect, at least 9 must pass, and the explain suite:
# 7 pair classes x 5 seeds (at least 4 of 5 each), 2 clean logs, the firmware-in-the-loop chain
# on sand and frozen grass, square / diagonal / manual, every form of the independent generator
# and its suite, 5 seeds per class (docs/workbench-suite.md).
test-full: test asan-full
	cd $(ASAN_BUILD) && ctest --output-on-failure -L sanitize_full -j $(JOBS)
	$(MAKE) board
	cd $(BUILD) && AUGER_BOARD_BUILD=$(abspath $(BOARD_BUILD)) ctest --output-on-failure -R '^board_qemu$$'
	cd $(BUILD) && AUGER_BOARD_BUILD=$(abspath $(BOARD_BUILD)) ctest --output-on-failure -L long
	$(MAKE) fuzz FUZZ_RUNS=5000000
	$(BUILD)/tests/robot/test_robot_fil "[.full]"
	$(BUILD)/tests/daemon/test_daemon "[.load_full]"
	python3 tests/workbench/hidden/run_hidden.py --auger $(BUILD)/host/auger/auger \
	  --sim-log $(BUILD)/sim/robot/auger-sim-log --seeds 10 --min-pass 9 --jobs 2
	python3 tests/workbench/hidden/run_explain.py --auger $(BUILD)/host/auger/auger \
	  --sim-log $(BUILD)/sim/robot/auger-sim-log --sim-drive $(BUILD)/sim/robot/auger-sim-drive \
	  --seeds 5 --min-frac 0.8 --jobs 2
	INDEP_ALL_FORMS=1 $(BUILD)/venv/bin/python3 -m pytest -q -p no:cacheprovider \
	  tests/workbench/indep/test_gen_indep.py
	$(BUILD)/venv/bin/python3 tests/workbench/indep/run_indep.py --auger $(BUILD)/host/auger/auger \
	  --seeds 5 --jobs 2 --json $(BUILD)/indep-results.json

# The simulated robot on sand driven by augerd: a square and the helix diagonal with each
# allocator, tracking errors printed (scripts/demo.sh; about 90 s after the build).
demo: host venv
	scripts/demo.sh $(BUILD)

bench-protocol: host
	$(BUILD)/tests/protocol/proto_corruption 1000000

bench-firmware: host
	$(BUILD)/bench/fw_bench

bench-host: host
	scripts/bench-host-step.sh $(BUILD)

bench-online: host
	scripts/bench-online.sh $(BUILD) 200 10

bench-online-fil: host
	scripts/bench-online-fil.sh $(BUILD)

bench-robot: host
	$(BUILD)/bench/robot_speed 20 2

bench-ros2: host venv
	scripts/bench-ros2.sh $(BUILD) 30

bench-explain: host
	scripts/bench-explain.sh $(BUILD) 3

bench-import: host venv
	scripts/bench-import.sh $(BUILD) 600 3600

# The paper's PID gains under every reading of their units (docs/firmware.md).
pid-units: host
	$(BUILD)/tests/fil/pid_units

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(FUZZ_BUILD)
	$(MAKE) -C firmware clean

# ---- The robot's board: A64-OLinuXino, Cortex-A53, aarch64 Debian 12 (issue 7, docs/board.md) ----
BOARD_BUILD ?= build-aarch64
BOARD_TARGETS := augerd auger auger-module
# make test builds for the board what runs the robot (augerd, auger-module) and runs board_qemu
# with the workstation's `auger` for `auger cmd` (AUGER_BOARD_CLI=host): the board's `auger`
# carries the workbench, whose aarch64 build was 150 s of CPU of make test (docs/benchmarks.md
# "Test-suite time"). make test-full builds all three and runs board_qemu with the board's.
BOARD_RUNTIME_TARGETS := augerd auger-module
# The same flags as cmake/toolchain-aarch64.cmake (which says why -ffp-contract=off).
BOARD_FLAGS := -mcpu=cortex-a53 -ffp-contract=off
ifeq ($(shell uname -m),aarch64)
BOARD_CMAKE := "-DCMAKE_C_FLAGS=$(BOARD_FLAGS)" "-DCMAKE_CXX_FLAGS=$(BOARD_FLAGS)"
else
BOARD_CMAKE := -DCMAKE_TOOLCHAIN_FILE=$(CURDIR)/cmake/toolchain-aarch64.cmake
endif

# augerd's ROS 2 interface (docs/ros2.md) is left out of the board's build unless ROS2=1: then
# Cyclone DDS comes from Debian's arm64 packages (multiarch on a workstation) and the board
# needs libddsc0debian to run augerd; without it augerd runs with nothing new and refuses
# [ros2] enabled = true, saying how to build it in.
ROS2 ?= 0
BOARD_ROS2 := $(if $(filter 1,$(ROS2)),ON,OFF)

# Only what building for the board needs (not the simulator, fuzzer or benchmark tools).
board-deps:
	@ROS2=$(ROS2) bash scripts/install-deps.sh board

# The simulator and the tests are off: they run on the workstation (tests/board runs these
# binaries under qemu-user there).
board: board-deps
	@[[ $(BOARD_ROS2) == ON ]] || echo "board: augerd without its ROS 2 interface (make board ROS2=1 to build it in; docs/ros2.md)"
	cmake -S . -B $(BOARD_BUILD) -G $(CMAKE_GENERATOR) -DCMAKE_BUILD_TYPE=Release \
	  -DAUGER_SANITIZE=OFF -DAUGER_WITH_SIM=OFF -DAUGER_WITH_ROS2=$(BOARD_ROS2) $(BOARD_CMAKE)
	cmake --build $(BOARD_BUILD) -j $(JOBS) --target $(BOARD_TARGETS)

# The unit tests of the board build, run under qemu-user (CMAKE_CROSSCOMPILING_EMULATOR of the
# toolchain file) or natively on aarch64: the host core's arithmetic on the board's ISA.
BOARD_TEST_TARGETS := test_protocol test_firmware_logic test_host_core
board-test: board
	cmake --build $(BOARD_BUILD) -j $(JOBS) --target $(BOARD_TEST_TARGETS)
	cd $(BOARD_BUILD) && ctest --output-on-failure

# No build here: on the board `make board` as the user, then `sudo make install`; or stage a
# tree on the workstation with DESTDIR and unpack it on the board. packaging/install.sh.
PREFIX ?= /usr/local
SYSCONFDIR ?= /etc
DESTDIR ?=
INSTALL_FROM ?= $(BOARD_BUILD)
install uninstall:
	FROM=$(abspath $(INSTALL_FROM)) DESTDIR=$(DESTDIR) PREFIX=$(PREFIX) SYSCONFDIR=$(SYSCONFDIR) \
	  bash packaging/install.sh $@

# The four modules on PORTS (id n for the n-th); the image is built here when avr-gcc is
# installed, else firmware/build/auger-module.hex must have been copied from a workstation.
# auger-module: the installed one, else that of $(BUILD) or $(BOARD_BUILD) that runs here.
PORTS ?=
flash-all:
	@[[ -n "$(PORTS)" ]] || { echo 'make flash-all PORTS="/dev/auger-module-0 ... -3"' >&2; exit 2; }
	if command -v avr-gcc >/dev/null; then $(MAKE) -C firmware; fi
	tool=$$(command -v auger-module || true); \
	for t in $(BUILD)/host/tools/auger-module $(BOARD_BUILD)/host/tools/auger-module; do \
	  [[ -n "$$tool" ]] || ! "$$t" --help >/dev/null 2>&1 || tool=$$t; \
	done; \
	AUGER_MODULE=$${tool:-auger-module} HEX=firmware/build/auger-module.hex scripts/flash-all.sh $(PORTS)

# The 100 Hz step on the board's CPU class: bench/host_step built for aarch64 and counted under
# qemu-user (instructions, not time), next to the x86 count; docs/benchmarks.md.
bench-board: board host
	scripts/bench-board.sh $(BOARD_BUILD) $(BUILD)

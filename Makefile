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
#   make asan        the unit and protocol tests with ASan+UBSan (build-asan/)
#   make fuzz        run the protocol parser fuzzer (FUZZ_RUNS, default unbounded: Ctrl-C)
#   make bench-protocol   XOR byte vs CRC-16 corruption figures (docs/protocol.md)
#   make bench-firmware   firmware cycles, edge rates, CPU load, simulation speed (docs/benchmarks.md)
#   make bench-host       instructions and time per host controller step (callgrind)
#   make bench-robot      speed of the whole simulated robot in lock-step
SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
JOBS ?= $(shell nproc)
BUILD ?= build
ASAN_BUILD ?= build-asan
FUZZ_BUILD ?= build-fuzz
CMAKE_GENERATOR ?= Ninja

AVR_CFLAGS := -mmcu=atmega328p -DF_CPU=16000000UL -std=c99 -Os -Wall -Wextra -Werror -pedantic
HOST_WARN := -Wall -Wextra -Werror -pedantic

.PHONY: all deps firmware flash host asan check-protocol fuzz fuzz-smoke test test-full demo \
        bench-protocol bench-firmware bench-host bench-robot pid-units clean

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

host: deps firmware
	cmake -S . -B $(BUILD) -G $(CMAKE_GENERATOR) -DCMAKE_BUILD_TYPE=Release -DAUGER_SANITIZE=OFF -DAUGER_WITH_SIM=ON
	cmake --build $(BUILD) -j $(JOBS)

# Only the programs of the `unit` tests are built here (a unit test missing from this list
# makes `ctest -L unit` below fail, not pass).
ASAN_TARGETS := test_protocol test_firmware_logic test_host_core test_sim_models \
                test_robot_unit test_daemon_unit
# W-data: the log generator's unit tests (tests/workbench/hidden)
ASAN_TARGETS += test_sim_log
# W-engine: the workbench engine's unit tests (tests/workbench/test_workbench_engine.cpp)
ASAN_TARGETS += test_workbench_engine
asan: deps firmware
	cmake -S . -B $(ASAN_BUILD) -G $(CMAKE_GENERATOR) -DCMAKE_BUILD_TYPE=Debug \
	  -DAUGER_SANITIZE=ON -DAUGER_WITH_SIM=ON
	cmake --build $(ASAN_BUILD) -j $(JOBS) --target $(ASAN_TARGETS)

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

test: deps check-protocol host asan fuzz-smoke
	cd $(ASAN_BUILD) && ctest --output-on-failure -L unit -j $(JOBS)
	cd $(BUILD) && ctest --output-on-failure

# Longer suites (docs/benchmarks.md has their times): the parser fuzzer for 5 million inputs,
# and the sand diagonal with the firmware in the loop across the blocking thresholds.
test-full: test
	$(MAKE) fuzz FUZZ_RUNS=5000000
	$(BUILD)/tests/robot/test_robot_fil "[.full]"
	# W-data: the hidden-effect suite, 10 seeds per effect, at least 9 must pass (docs/workbench-suite.md)
	python3 tests/workbench/hidden/run_hidden.py --auger $(BUILD)/host/auger/auger \
	  --sim-log $(BUILD)/sim/robot/auger-sim-log --seeds 10 --min-pass 9 --jobs 2

# The simulated robot on sand driven by augerd: a square and the helix diagonal with each
# allocator, tracking errors printed (scripts/demo.sh; about 90 s after the build).
demo: host
	scripts/demo.sh $(BUILD)

bench-protocol: host
	$(BUILD)/tests/protocol/proto_corruption 1000000

bench-firmware: host
	$(BUILD)/bench/fw_bench

bench-host: host
	scripts/bench-host-step.sh $(BUILD)

bench-robot: host
	$(BUILD)/bench/robot_speed 20 2

# The paper's PID gains under every reading of their units (docs/firmware.md).
pid-units: host
	$(BUILD)/tests/fil/pid_units

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(FUZZ_BUILD)
	$(MAKE) -C firmware clean

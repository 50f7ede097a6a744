// `make flash` without hardware: the real avrdude flashes the firmware image through Debian's
// Optiboot into a simulated ATmega328P over a pty (paced to real time: avrdude's timeouts are
// wall-clock), then scripts/flash-module.sh sets the id through a CONFIG frame with
// auger-module, and the flashed module answers with its new id.
#include "simmod.h"

#include <catch2/catch.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

extern char** environ;

namespace {

const char* const kOptiboot =
    "/usr/share/arduino/hardware/arduino/avr/bootloaders/optiboot/optiboot_atmega328.hex";

// Runs argv with stdout+stderr to `log`, stepping the simulation in real time meanwhile.
int run_with_sim(simmod_t* sim, const std::vector<std::string>& args, const std::string& log,
                 double timeout_s)
{
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    pid_t pid;
    REQUIRE(posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ) == 0);
    posix_spawn_file_actions_destroy(&fa);
    int status = 0;
    const double end = simmod_time_s(sim) + timeout_s;
    while (waitpid(pid, &status, WNOHANG) == 0) {
        if (simmod_time_s(sim) > end) {
            kill(pid, SIGKILL);
            waitpid(pid, &status, 0);
            return -1;
        }
        simmod_step_to(sim, simmod_time_s(sim) + 0.01);
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const std::string& path)
{
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

}  // namespace

TEST_CASE("make flash: avrdude through Optiboot, then the id through a CONFIG frame", "[fil][flash]")
{
    REQUIRE(access(kOptiboot, R_OK) == 0);  // arduino-core-avr, installed by scripts/install-deps.sh
    char dir[] = "/tmp/auger-fil-flash-XXXXXX";
    REQUIRE(mkdtemp(dir) != nullptr);

    simmod_config_t cfg;
    simmod_config_default(&cfg);
    cfg.elf_path = AUGER_OLD_IMAGE_ELF;  // what the module ran before: not the auger firmware
    cfg.pty_dir = dir;
    cfg.realtime = 1;
    cfg.reset_on_open = 1;  // as DTR does on the module's USB serial adapter
    cfg.bootloader_hex = kOptiboot;
    simmod_t* sim = simmod_create(&cfg);
    REQUIRE(sim != nullptr);
    simmod_set_battery_voltage(sim, 0, 18.0);
    const std::string port = simmod_pty_link(sim, 0);
    const std::string log = std::string(dir) + "/flash.log";

    setenv("AUGER_MODULE", AUGER_MODULE_TOOL, 1);
    int rc = run_with_sim(sim, {"/bin/bash", AUGER_FLASH_SCRIPT, port, AUGER_FIRMWARE_HEX, "3"}, log, 60.0);
    std::string out = slurp(log);
    INFO(out);
    REQUIRE(rc == 0);
    CHECK(out.find("flashed") != std::string::npos);
    CHECK(out.find("module 3, firmware") != std::string::npos);

    // A fresh open (the module resets again) finds the new firmware with the id in EEPROM.
    rc = run_with_sim(sim, {AUGER_MODULE_TOOL, port, "identify"}, log, 20.0);
    out = slurp(log);
    INFO(out);
    CHECK(rc == 0);
    CHECK(out.find("module 3, firmware 0.2.0, protocol 2, settings from EEPROM") != std::string::npos);
    // Optiboot cleared MCUSR; RAM kept the previous run's marker: the identity says warm.
    CHECK(out.find("last reset: warm reset") != std::string::npos);

    simmod_destroy(sim);
    std::remove(log.c_str());
    rmdir(dir);
}

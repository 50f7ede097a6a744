// Speed of the whole simulated robot in lock-step simulated time, as a multiple of real time:
// four modules (firmware in the loop, or ideal screws), the true robot on frozen grass, the
// sensors and the host controller at 100 Hz tracking a 0.5 m square (docs/benchmarks.md,
// make bench-robot).   robot_speed [--elf PATH] [SECONDS] [THREADS]
#include "auger/args.hpp"
#include "auger/controller.hpp"
#include "auger/model_file.hpp"
#include "scheduler.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace auger;

namespace {

std::string g_elf = AUGER_FIRMWARE_ELF;

double run(sim::ScrewMode mode, double seconds, int threads, const ModelFile& file)
{
    const Model model = build_model(file, "frozen_grass");
    Controller c(model, controller_config(file, "frozen_grass"));
    sim::TruthParams truth;
    sim::SchedulerConfig sc;
    sc.mode = mode;
    sc.elf_path = g_elf;
    sc.threads = threads;
    sc.terrain = "frozen_grass";
    sim::Scheduler s(model, truth, sc);
    s.set_keep_history(false);
    s.set_controller(&c);
    s.run_until(0.1);  // modules boot
    c.set_waypoints({{0, Vec3(0, 0, 0)}, {10, Vec3(0.5, 0, 0)}, {20, Vec3(0.5, 0.5, 0)},
                     {30, Vec3(0, 0.5, 0)}, {40, Vec3(0, 0, 0)}});
    c.set_enabled(true);
    auto t0 = std::chrono::steady_clock::now();
    s.run_until(0.1 + seconds);
    double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return seconds / wall_s;
}

}  // namespace

int main(int argc, char** argv)
{
    const auger::CommandLine cli{
        "robot_speed", "[OPTIONS] [SECONDS (20)] [THREADS (2)]",
        "The whole robot with four firmware modules, and with ideal screws, as a multiple of real\n"
        "time (docs/benchmarks.md).\n",
        {{"--elf", "PATH", "another firmware image, e.g. to compare (default: the one built)"}},
        ""};
    auger::Args args;
    if (const int rc = cli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
    if (args.has("--elf")) g_elf = args.get("--elf");
    double seconds = 20.0, threads_d = 2;
    const auto& pos = args.positional;
    if (pos.size() > 2 || (pos.size() > 0 && !auger::Args::to_number("robot_speed", "SECONDS", pos[0], seconds)) ||
        (pos.size() > 1 && !auger::Args::to_number("robot_speed", "THREADS", pos[1], threads_d)) || seconds <= 0 ||
        threads_d < 1 || threads_d != double(int(threads_d))) {
        std::fprintf(stderr, "robot_speed: SECONDS > 0 and a whole THREADS >= 1\n");
        cli.print_usage(stderr);
        return 2;
    }
    const int threads = int(threads_d);
    const ModelFile file = load_model_file(AUGER_MODELS_DIR "/robot.toml");
    std::printf("| screws | threads | simulated s | x real time |\n|---|---|---|---|\n");
    std::printf("| firmware in the loop | %d | %.0f | %.1fx |\n", threads, seconds,
                run(sim::ScrewMode::fil, seconds, threads, file));
    std::printf("| ideal | - | %.0f | %.0fx |\n", seconds, run(sim::ScrewMode::ideal, seconds, 1, file));
    return 0;
}

// The host controller's 100 Hz step (estimation + control + allocation, auger_core) on the
// robot model on sand, tracking a 0.5 m square, with a camera pose every 3rd step and the IMU
// every step. Prints wall-clock time per step for each estimator x allocator. The instruction
// count per step comes from callgrind: scripts/bench-host-step.sh (make bench-host) runs this
// program twice with different step counts and divides the difference.
//   host_step [STEPS] [ekf|dr] [nullspace|pinv]
#include "auger/args.hpp"
#include "auger/controller.hpp"
#include "auger/model_file.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace auger;

namespace {

double run(const Model& model, ControllerConfig cfg, long steps)
{
    Controller c(model, cfg);
    c.reset(Vec3::Zero());
    c.set_waypoints({{0, Vec3(0, 0, 0)}, {10, Vec3(0.5, 0, 0)}, {20, Vec3(0.5, 0.5, 0)},
                     {30, Vec3(0, 0.5, 0)}, {40, Vec3(0, 0, 0)}});
    c.set_enabled(true);
    std::array<ScrewTelemetry, 4> tel{};
    SensorInput sens;
    std::array<double, 4> last{};
    double checksum = 0;
    auto t0 = std::chrono::steady_clock::now();
    for (long k = 0; k < steps; ++k) {
        const double t_s = 0.01 * double(k);
        for (int i = 0; i < 4; ++i) tel[size_t(i)] = {last[size_t(i)] * 0.9, true};
        sens.has_pose = (k % 3) == 0;
        sens.pose = c.eta_estimate();
        sens.has_imu_psi = sens.has_imu_r = true;
        sens.imu_psi_rad = c.eta_estimate()(2);
        sens.imu_r_radps = c.zeta_estimate()(2);
        last = c.step(t_s, tel, sens);
        checksum += last[0];
    }
    auto t1 = std::chrono::steady_clock::now();
    if (!std::isfinite(checksum)) std::fprintf(stderr, "host_step: non-finite setpoints\n");
    return std::chrono::duration<double>(t1 - t0).count() / double(steps);
}

}  // namespace

int main(int argc, char** argv)
{
    const auger::CommandLine cli{
        "host_step", "[STEPS (20000)] [ESTIMATOR (ekf|dr)] [ALLOCATOR (nullspace|pinv)]",
        "The host controller's step (estimation, control, allocation) timed per call, for each\n"
        "estimator and allocator or the ones named (docs/benchmarks.md).\n",
        {},
        ""};
    auger::Args args;
    if (const int rc = cli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
    const auto& pos = args.positional;
    double steps_d = 20000;
    if (pos.size() > 3 || (!pos.empty() && !auger::Args::to_number("host_step", "STEPS", pos[0], steps_d)) ||
        steps_d < 1 || steps_d != double(long(steps_d))) {
        std::fprintf(stderr, "host_step: STEPS must be a positive integer\n");
        return 2;
    }
    const long steps = long(steps_d);
    ModelFile file = load_model_file(AUGER_MODELS_DIR "/robot.toml");
    Model model = build_model(file, "sand");
    struct Case {
        const char* est;
        EstimatorKind e;
        const char* alloc;
        AllocatorKind a;
    };
    const Case cases[] = {{"ekf", EstimatorKind::ekf, "nullspace", AllocatorKind::null_space},
                          {"ekf", EstimatorKind::ekf, "pinv", AllocatorKind::pseudo_inverse},
                          {"dr", EstimatorKind::dead_reckoning, "nullspace", AllocatorKind::null_space},
                          {"dr", EstimatorKind::dead_reckoning, "pinv", AllocatorKind::pseudo_inverse}};
    const std::string want_est = pos.size() > 1 ? pos[1] : "", want_alloc = pos.size() > 2 ? pos[2] : "";
    for (const Case& k : cases) {
        if (!want_est.empty() && want_est != k.est) continue;
        if (!want_alloc.empty() && want_alloc != k.alloc) continue;
        ControllerConfig cfg = controller_config(file, "sand");
        cfg.estimator = k.e;
        cfg.allocator.kind = k.a;
        double s = run(model, cfg, steps);
        std::printf("| %s | %s | %.2f us | %.4f %% |\n", k.est, k.alloc, s * 1e6, s / 0.01 * 100);
    }
    return 0;
}

// auger replay LOG...: runs the core's estimator and controller offline on augerd's log(s) and
// reports where their outputs differ from what augerd logged (cmd_rpm_i, the estimate
// xe_m/ye_m/psie_rad, the reference xd_m/yd_m/psid_rad): a regression check after a change to
// the core or the gains. The log's replay columns (docs/daemon.md "The log") give the inputs
// augerd's controller saw each cycle: the fresh telemetry, the sensor messages with their
// standard deviations, and the commands that changed its state. docs/operator.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "auger/args.hpp"
#include "auger/controller.hpp"
#include "auger/daemon_config.hpp"
#include "auger/daemon_log.hpp"
#include "auger/log.hpp"
#include "auger/model_file.hpp"
#include "common.hpp"
#include "operator.hpp"

namespace auger::op {
namespace {

using daemon::kEvDisabled;
using daemon::kEvRebuilt;
using daemon::kEvWaypoints;
using daemon::Mode;
using daemon::mode_code;

struct Compared {
  Compared(std::string c, double t) : column(std::move(c)), tol(t) {}
  std::string column;
  double tol;
  int col = -1;
  double max_diff = 0;
  long n = 0;
  bool differs = false;
  double first_t_s = NAN, first_logged = NAN, first_replayed = NAN;
  int first_line = 0;
  std::string file;
  void check(double logged, double replayed, double t_s, int line, const std::string& name, bool angle = false) {
    if (std::isnan(logged)) return;
    double d = std::fabs(replayed - logged);
    if (angle) d = std::fabs(wrap_angle(replayed - logged));
    if (std::isnan(d)) d = INFINITY;
    ++n;
    max_diff = std::max(max_diff, d);
    if (d > tol && !differs) {
      differs = true;
      first_t_s = t_s, first_logged = logged, first_replayed = replayed, first_line = line, file = name;
    }
  }
};

const CommandLine& replay_cli() {
  static const CommandLine cli{
      "auger replay",
      "LOG... (--config AUGERD_TOML | --model MODEL_TOML [--terrain NAME]) [OPTIONS]",
      "Reruns the estimator and controller on augerd's log files (in order: the files of one run\n"
      "after rotation) with the controller settings of augerd's configuration (or the model file's\n"
      "defaults for the log's terrain) and compares cmd_rpm_0..3, the estimate xe_m ye_m psie_rad\n"
      "and the reference xd_m yd_m psid_rad.\n",
      {{"--config", "AUGERD_TOML", "augerd's configuration: its model, terrain and controller settings"},
       {"--model", "MODEL_TOML", "a model file instead, with its defaults for the terrain"},
       {"--terrain", "NAME", "with --model (default: the log's '# terrain:')"},
       {"--tol-rpm", "X", "tolerance of cmd_rpm_i (default 1e-6 rpm)"},
       {"--tol-m", "X", "tolerance of the positions (default 1e-6 m)"},
       {"--tol-rad", "X", "tolerance of the angles (default 1e-6 rad)"}},
      "Exit 0: same; 1: they differ (first differing sample and largest difference per column\n"
      "printed); 2: bad input (file:line:column).\n"};
  return cli;
}

void replay_usage(std::FILE* f) { replay_cli().print_usage(f); }

}  // namespace

int run_replay(int argc, char** argv) {
  std::vector<std::string> logs;
  std::string config_path, model_path, terrain;
  double tol_rpm = 1e-6, tol_m = 1e-6, tol_rad = 1e-6;
  try {
    Args a;
    if (const int rc = replay_cli().parse_or_answer(argc, argv, a); rc >= 0) return rc;
    if (!a.number("auger replay", "--tol-rpm", tol_rpm, tol_rpm) || !a.number("auger replay", "--tol-m", tol_m, tol_m) ||
        !a.number("auger replay", "--tol-rad", tol_rad, tol_rad))
      return replay_usage(stderr), 2;
    config_path = a.get("--config");
    model_path = a.get("--model");
    terrain = a.get("--terrain");
    logs = a.positional;
    if (logs.empty()) throw UsageError("no log given");
    if (config_path.empty() == model_path.empty()) throw UsageError("give exactly one of --config and --model");
  } catch (const UsageError& e) {
    std::fprintf(stderr, "auger replay: %s\n", e.what());
    replay_usage(stderr);
    return 2;
  }
  try {
    // The controller as augerd built it.
    std::optional<Model> model;
    ControllerConfig ccfg;
    if (!config_path.empty()) {
      // Whether this build could run augerd's ROS 2 bridge does not matter to a replay.
      const DaemonConfig dc = read_daemon_config(config_path, /*ros2_available=*/true, /*ros2_security_stated=*/false);
      model = build_model(load_model_file(dc.model_file), dc.terrain);
      ccfg = dc.controller;
    } else {
      if (terrain.empty()) {
        CsvLogReader first(logs[0]);
        terrain = first.meta("terrain").value_or("");
        if (terrain.empty()) throw UsageError(logs[0] + ": no '# terrain:' metadata; give --terrain");
      }
      const ModelFile mf = load_model_file(model_path);
      model = build_model(mf, terrain);
      ccfg = controller_config(mf, terrain);
    }
    // The log's allocator, not the configuration's: `allocator` commands change it.
    std::unique_ptr<Controller> ctrl = std::make_unique<Controller>(*model, ccfg);

    std::vector<Compared> cmp;
    for (int i = 0; i < 4; ++i) cmp.push_back({"cmd_rpm_" + std::to_string(i), tol_rpm});
    cmp.push_back({"xe_m", tol_m});
    cmp.push_back({"ye_m", tol_m});
    cmp.push_back({"psie_rad", tol_rad});
    cmp.push_back({"xd_m", tol_m});
    cmp.push_back({"yd_m", tol_m});
    cmp.push_back({"psid_rad", tol_rad});
    long rows = 0;
    double last_t_s = -INFINITY;
    for (const auto& path : logs) {
      CsvLogReader r(path);
      r.check_format(kRobotLogFormat);
      const std::string run = r.meta("run").value_or("");
      const std::string dir = path.find('/') == std::string::npos ? "." : path.substr(0, path.rfind('/'));
      // augerd's replay columns and the standard ones the replay reads.
      std::vector<std::string> need = daemon::replay_columns();
      for (const char* c : {"x_m", "y_m", "psi_rad", "imu_psi_rad", "imu_r_radps", "xd_m", "yd_m", "psid_rad"})
        need.push_back(c);
      for (int i = 0; i < 4; ++i)
        for (const char* c : {"omega_rpm_", "cmd_rpm_"}) need.push_back(c + std::to_string(i));
      r.require_columns(need);
      auto col = [&](const std::string& n) { return r.column_index(n); };
      for (auto& c : cmp) c.col = col(c.column);
      while (r.next()) {
        if (!(r.t_s() > last_t_s)) r.fail_at_field(col("t_s"), "t_s does not continue the previous file's");
        last_t_s = r.t_s();
        ++rows;
        auto v = [&](const std::string& n) { return r.value(col(n)); };
        const int events = int(v("ctrl_events"));
        // The state changes of this cycle, in the order augerd makes them (docs/daemon.md).
        if (events & kEvRebuilt) {
          ControllerConfig c2 = ccfg;
          c2.allocator.kind = v("alloc_nullspace") == 1 ? AllocatorKind::null_space : AllocatorKind::pseudo_inverse;
          const Vec3 eta = ctrl->eta_estimate();
          ctrl = std::make_unique<Controller>(*model, c2);
          ctrl->reset(eta);
        } else if (rows == 1) {
          ControllerConfig c2 = ccfg;
          c2.allocator.kind = v("alloc_nullspace") == 1 ? AllocatorKind::null_space : AllocatorKind::pseudo_inverse;
          ctrl = std::make_unique<Controller>(*model, c2);
        }
        if (events & kEvDisabled) ctrl->set_enabled(false);
        if (events & kEvWaypoints) {
          if (!std::isnan(v("goal_x_m"))) {
            ctrl->set_waypoints({Waypoint{0.0, Vec3(v("goal_x_m"), v("goal_y_m"), v("goal_psi_rad"))}});
          } else if (!std::isnan(v("traj_n"))) {
            const std::string traj = dir + "/" + run + "-follow-" + std::to_string(int(v("traj_n"))) + ".waypoints";
            ctrl->set_waypoints(load_waypoints_csv(traj));
          } else {
            r.fail_at_field(col("ctrl_events"), "new waypoints but neither goal_x_m nor traj_n");
          }
        }
        if (v("ctrl_enabled") == 1) ctrl->set_enabled(true);
        else ctrl->set_enabled(false);

        std::array<ScrewTelemetry, 4> tel;
        for (int i = 0; i < 4; ++i) {
          const std::string s = std::to_string(i);
          tel[std::size_t(i)].valid = v("tm_fresh_" + s) == 1;
          tel[std::size_t(i)].omega_rpm = tel[std::size_t(i)].valid ? v("omega_rpm_" + s) : 0.0;
          if (tel[std::size_t(i)].valid && std::isnan(tel[std::size_t(i)].omega_rpm))
            r.fail_at_field(col("omega_rpm_" + s), "fresh telemetry without omega_rpm_" + s);
        }
        SensorInput sin;
        if (!std::isnan(v("x_m"))) {
          sin.has_pose = true;
          sin.pose = Vec3(v("x_m"), v("y_m"), v("psi_rad"));
          const Vec3 sd(v("pose_sx_m"), v("pose_sy_m"), v("pose_spsi_rad"));
          sin.pose_cov = Vec3(sd[0] * sd[0], sd[1] * sd[1], sd[2] * sd[2]).asDiagonal();
          sin.pose_t_s = v(daemon::pose_capture_column());
        }
        if (!std::isnan(v("imu_psi_rad"))) {
          sin.has_imu_psi = sin.has_imu_r = true;
          sin.imu_psi_rad = v("imu_psi_rad");
          sin.imu_r_radps = v("imu_r_radps");
        }
        const std::array<double, 4> ctrl_rpm = ctrl->step(r.t_s(), tel, sin);
        // What augerd sent (Daemon::setpoints, host/augerd/daemon.cpp): the controller in goto/follow/hold, eq. (4)
        // scaled to omega_max_rpm in vel, one module in spin, else 0.
        std::array<double, 4> cmd{};
        const int mode = int(v("mode"));
        const double lim = ctrl->config().allocator.omega_max_rpm;
        if (mode == mode_code(Mode::go_to) || mode == mode_code(Mode::follow) || mode == mode_code(Mode::hold)) {
          cmd = ctrl_rpm;
        } else if (mode == mode_code(Mode::vel) && !std::isnan(v("vel_u_mps"))) {
          const Vec4 w = kinematic_screw_speeds_rpm(*model, Vec3(v("vel_u_mps"), v("vel_v_mps"), v("vel_r_radps")));
          const double peak = w.cwiseAbs().maxCoeff();
          const double scale = peak > lim ? lim / peak : 1.0;
          for (int i = 0; i < 4; ++i) cmd[std::size_t(i)] = w[i] * scale;
        } else if (mode == mode_code(Mode::spin) && !std::isnan(v("spin_module"))) {
          cmd[std::size_t(v("spin_module"))] = std::clamp(v("spin_rpm"), -lim, lim);
        }
        const int line = r.line();
        for (int i = 0; i < 4; ++i) cmp[std::size_t(i)].check(r.value(cmp[std::size_t(i)].col), cmd[std::size_t(i)], r.t_s(), line, path);
        const Vec3& eta = ctrl->eta_estimate();
        cmp[4].check(v("xe_m"), eta[0], r.t_s(), line, path);
        cmp[5].check(v("ye_m"), eta[1], r.t_s(), line, path);
        cmp[6].check(v("psie_rad"), eta[2], r.t_s(), line, path, true);
        if (ctrl->enabled()) {
          const Vec3& d = ctrl->reference().eta_d;
          cmp[7].check(v("xd_m"), d[0], r.t_s(), line, path);
          cmp[8].check(v("yd_m"), d[1], r.t_s(), line, path);
          cmp[9].check(v("psid_rad"), d[2], r.t_s(), line, path, true);
        }
      }
    }
    bool differs = false;
    std::printf("replayed %ld rows of %zu file(s)\n", rows, logs.size());
    std::printf("%-10s %8s %12s %10s  %s\n", "column", "samples", "max |diff|", "tolerance", "first difference");
    for (const auto& c : cmp) {
      std::printf("%-10s %8ld %12.3g %10.3g  ", c.column.c_str(), c.n, c.max_diff, c.tol);
      if (c.differs)
        std::printf("%s:%d t_s=%.3f logged %.6g, replayed %.6g\n", c.file.c_str(), c.first_line, c.first_t_s,
                    c.first_logged, c.first_replayed);
      else
        std::printf("-\n");
      differs = differs || c.differs;
    }
    std::printf("%s\n", differs ? "DIFFERENT: the replayed controller does not reproduce the log" : "same: the log is reproduced");
    return differs ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger replay: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::op

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
#include "auger/log.hpp"
#include "auger/model_file.hpp"
#include "common.hpp"
#include "daemon_config.hpp"
#include "daemon_lines.hpp"
#include "daemon_log.hpp"
#include "operator.hpp"

namespace auger::op {
namespace {

using daemon::kEvDisabled;
using daemon::kEvRebuilt;
using daemon::kEvWaypoints;
using daemon::LogRow;
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
      model = build_model(dc.model, dc.terrain);
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
      // augerd's replay columns (LogRow) and the standard ones the replay reads.
      const daemon::LogRowReader rows_of(r);
      std::vector<std::string> need;
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
        const LogRow row = rows_of.row();
        const int events = int(row.ctrl_events);
        // The state changes of this cycle, in the order augerd makes them (docs/daemon.md).
        if (events & kEvRebuilt) {
          ControllerConfig c2 = ccfg;
          c2.allocator.kind = row.alloc_nullspace == 1 ? AllocatorKind::null_space : AllocatorKind::pseudo_inverse;
          const Vec3 eta = ctrl->eta_estimate();
          ctrl = std::make_unique<Controller>(*model, c2);
          ctrl->reset(eta);
        } else if (rows == 1) {
          ControllerConfig c2 = ccfg;
          c2.allocator.kind = row.alloc_nullspace == 1 ? AllocatorKind::null_space : AllocatorKind::pseudo_inverse;
          ctrl = std::make_unique<Controller>(*model, c2);
        }
        if (events & kEvDisabled) ctrl->set_enabled(false);
        if (events & kEvWaypoints) {
          if (!std::isnan(row.goal_x_m)) {
            ctrl->set_waypoints({Waypoint{0.0, Vec3(row.goal_x_m, row.goal_y_m, row.goal_psi_rad)}});
          } else if (!std::isnan(row.traj_n)) {
            const std::string traj = dir + "/" + run + "-follow-" + std::to_string(int(row.traj_n)) + ".waypoints";
            ctrl->set_waypoints(load_waypoints_csv(traj));
          } else {
            r.fail_at_field(col("ctrl_events"), "new waypoints but neither goal_x_m nor traj_n");
          }
        }
        if (row.ctrl_enabled == 1) ctrl->set_enabled(true);
        else ctrl->set_enabled(false);

        const double fresh[4] = {row.tm_fresh_0, row.tm_fresh_1, row.tm_fresh_2, row.tm_fresh_3};
        std::array<ScrewTelemetry, 4> tel;
        for (int i = 0; i < 4; ++i) {
          const std::string s = std::to_string(i);
          tel[std::size_t(i)].valid = fresh[i] == 1;
          tel[std::size_t(i)].omega_rpm = tel[std::size_t(i)].valid ? v("omega_rpm_" + s) : 0.0;
          if (tel[std::size_t(i)].valid && std::isnan(tel[std::size_t(i)].omega_rpm))
            r.fail_at_field(col("omega_rpm_" + s), "fresh telemetry without omega_rpm_" + s);
        }
        // The sensor messages of the row, as augerd turned them into the controller's input.
        SensorInput sin;
        if (!std::isnan(v("x_m"))) {
          daemon::SensorMessage pose;
          pose.kind = daemon::SensorKind::pose;
          pose.x_m = v("x_m"), pose.y_m = v("y_m"), pose.psi_rad = v("psi_rad");
          pose.sx_m = row.pose_sx_m, pose.sy_m = row.pose_sy_m, pose.spsi_rad = row.pose_spsi_rad;
          daemon::to_sensor_input(pose, row.pose_capture_t_s, sin);
        }
        if (!std::isnan(v("imu_psi_rad"))) {
          daemon::SensorMessage imu;
          imu.kind = daemon::SensorKind::imu;
          imu.imu_psi_rad = v("imu_psi_rad"), imu.imu_r_radps = v("imu_r_radps");
          daemon::to_sensor_input(imu, r.t_s(), sin);
        }
        const std::array<double, 4> ctrl_rpm = ctrl->step(r.t_s(), tel, sin);
        // What augerd sent: the same rule (auger_contract's mode_setpoints) on the logged mode and
        // its command; a row whose mode lacks its command sent nothing.
        daemon::MotionInput motion;
        const int mode = int(row.mode);
        for (Mode m : {Mode::stopped, Mode::idle, Mode::vel, Mode::go_to, Mode::follow, Mode::hold, Mode::spin})
          if (mode == mode_code(m)) motion.mode = m;
        if (motion.mode == Mode::vel && std::isnan(row.vel_u_mps)) motion.mode = Mode::idle;
        if (motion.mode == Mode::spin && !(row.spin_module >= 0 && row.spin_module <= 3)) motion.mode = Mode::idle;
        if (motion.mode == Mode::vel) motion.vel = Vec3(row.vel_u_mps, row.vel_v_mps, row.vel_r_radps);
        if (motion.mode == Mode::spin) motion.spin_module = int(row.spin_module), motion.spin_rpm = row.spin_rpm;
        const std::array<double, 4> cmd =
            daemon::mode_setpoints(motion, ctrl_rpm, *model, ctrl->config().allocator.omega_max_rpm);
        const int line = r.line();
        for (int i = 0; i < 4; ++i) cmp[std::size_t(i)].check(r.value(cmp[std::size_t(i)].col), cmd[std::size_t(i)], r.t_s(), line, path);
        const Vec3& eta = ctrl->eta_estimate();
        cmp[4].check(row.xe_m, eta[0], r.t_s(), line, path);
        cmp[5].check(row.ye_m, eta[1], r.t_s(), line, path);
        cmp[6].check(row.psie_rad, eta[2], r.t_s(), line, path, true);
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

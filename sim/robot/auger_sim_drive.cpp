// auger-sim-drive: a robot log as augerd writes it, made in lock-step (docs/robot-sim.md
// "auger-sim-drive"): four modules running the real firmware image (or ideal screws), the
// physical robot (Coriolis terms, the real lever arms' yaw, blocking of stopped screws on sand),
// the simulated camera and IMU, driven by the host controller along a square or the helix
// diagonal (as `auger cmd follow`), or open loop by a simulated joystick through eq. (4) (as
// `auger cmd vel`). Batch, not paced: a 240 s log takes seconds. With --field the ground under
// each screw changes with place (field.hpp, docs/robot-sim.md "Fields").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <random>
#include <string>

#include "auger/args.hpp"
#include "auger/kinematic_velocity.hpp"
#include "auger/model_file.hpp"
#include "auger/online_estimator.hpp"
#include "daemon_log.hpp"
#include "scheduler.hpp"

namespace {

const auger::CommandLine kCli{
    "auger-sim-drive",
    "--out LOG [OPTIONS]",
    "A robot log in augerd's format from the lock-step scheduler: the firmware image in four\n"
    "simulated modules, the physical robot on the terrain, camera and IMU; driven by the host\n"
    "controller around 0.5 m squares or back and forth along the helix diagonal, or by a\n"
    "simulated joystick (manual: body velocities through eq. (4), as augerd's vel). With --field\n"
    "the terrain changes where the robot is (patches of a field file, docs/robot-sim.md).\n",
    {{"--out", "LOG", "the log to write"},
     {"--drive", "square|diagonal|manual", "what drives the robot (default square)"},
     {"--terrain", "sand|frozen_grass", "the (controller's) terrain (default sand; the field's background)"},
     {"--field", "FILE", "terrain patches in the world frame (e.g. sim/fields/sand-grass.toml)"},
     {"--course-m", "L", "square side, diagonal length (default 0.5 m; docs/robot-sim.md)"},
     {"--seconds", "S", "the log's length (default 240 s)"},
     {"--seed", "N", "the random seed (default 1)"},
     {"--screws", "fil|ideal", "firmware in the loop, or first-order screws (default fil)"},
     {"--blocking-rpm", "X", "screws slower than X block (default 1.5 rpm on sand, 0 = off; a patch's own wins)"},
     {"--model", "PATH", "the model file (default " AUGER_DEFAULT_MODEL ")"},
     {"--elf", "PATH", "the firmware image (default " AUGER_DEFAULT_ELF ")"},
     {"--threads", "N", "simulation threads (default 1)"},
     {"--truth-out", "FILE", "write the true pose and the ground under the robot there"},
     {"--course-out", "FILE", "write the course as augerd's follow file (t_s,x_m,y_m,psi_rad); alone: nothing else"},
     {"--camera-corr-s", "S", "correlation time of the camera's noise (default 0.3 s)"},
     {"--camera-latency-s", "S", "the camera's capture-to-delivery latency (default 0.03 s)"},
     {"--online-apply", "", "the controller takes the online estimate, as augerd's [online] apply = true with\n"
                            "the settings of scripts/online-fil.sh (kinematic velocity, drag held, slow_screw_rpm 2)"},
     {"--online-slow-screw-rpm", "X", "with --online-apply: [online] slow_screw_rpm (default 2)"},
     {"--effect-feedforward", "", "the controller feeds the model's effect forces forward, as augerd's\n"
                                  "[control] effect_feedforward = true (e.g. a slope in --model, or estimated with --online-apply)"},
     {"--incline-pitch-rad", "P", "the ground tilted by P about world y (descending towards +x for P > 0; truth's incline)"},
     {"--incline-roll-rad", "R", "the ground tilted by R about world x (descending towards -y for R > 0)"}},
    "Exit 2: bad usage.\n"};

void usage(std::FILE* f) { kCli.print_usage(f); }

double number(const char* opt, const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(v)) {
    std::fprintf(stderr, "auger-sim-drive: %s: '%s' is not a number\n", opt, text);
    std::exit(2);
  }
  return v;
}

// A person with a joystick: every 1.5-5 s a new stick position (stop, one DOF, or a mix; forward
// more often than back), followed through a 0.5 s first-order smoothing; body velocities.
class Joystick {
 public:
  explicit Joystick(std::uint64_t seed) : rng_(seed * 7919 + 101) {}
  auger::Vec3 at(double t_s, double dt_s) {
    std::uniform_real_distribution<double> u01(0, 1), hold(1.5, 5.0);
    if (t_s >= next_s_) {
      next_s_ = t_s + hold(rng_);
      const double kind = u01(rng_);
      target_.setZero();
      const double u = -0.03 + 0.11 * u01(rng_), v = -0.06 + 0.12 * u01(rng_), r = -0.25 + 0.5 * u01(rng_);
      if (kind < 0.15) {
      } else if (kind < 0.5) {
        const int d = static_cast<int>(u01(rng_) * 3.0) % 3;
        target_[d] = d == 0 ? u : d == 1 ? v : r;
      } else {
        target_ = auger::Vec3(u, v, r);
      }
    }
    stick_ += (1.0 - std::exp(-dt_s / 0.5)) * (target_ - stick_);
    return stick_;
  }

 private:
  std::mt19937_64 rng_;
  double next_s_ = 0;
  auger::Vec3 target_ = auger::Vec3::Zero(), stick_ = auger::Vec3::Zero();
};

// The square (a corner every 12 s per 0.5 m) or the helix diagonal (back and forth, 20 s a leg per
// 0.5 m) of --course-m, as `follow` waypoints (t from the start of following).
std::vector<auger::Waypoint> course(const std::string& drive, double course_m, double seconds, const auger::Model& m) {
  using auger::Vec3;
  std::vector<auger::Waypoint> wps;
  const double scale = course_m / 0.5;  // the demo's courses are 0.5 m
  const double leg_s = (drive == "square" ? 12.0 : 20.0) * scale;
  // A leg longer than the demo's is a ramp of 0.1 m set-point steps over its first 3/4
  // share, then a hold: the reference model (eq. (18), time constant 1 / gamma = 5 s) then
  // moves at nearly the ramp's mean speed, arrives, and dwells only at the corners and ends,
  // not on its way (e.g. on a field's edge).
  const int steps = scale > 1 ? static_cast<int>(std::ceil(course_m / 0.1 - 1e-9)) : 1;
  const double ramp = scale > 1 ? 0.75 : 1.0;
  const double diag = std::atan2(m.terrain.sigma_lat / m.terrain.D_y, m.terrain.sigma_long / m.terrain.D_x);
  Vec3 from = Vec3::Zero();
  for (int k = 1; (k - 1) * leg_s + ramp * leg_s / steps <= seconds; ++k) {
    Vec3 p = Vec3::Zero();
    if (drive == "square") {
      static const double corners[4][2] = {{0.5, 0}, {0.5, 0.5}, {0, 0.5}, {0, 0}};
      p << corners[(k - 1) % 4][0] * scale, corners[(k - 1) % 4][1] * scale, 0;
    } else if (k % 2 == 1) {
      p << course_m * std::cos(diag), course_m * std::sin(diag), 0;
    }
    for (int j = 1; j < steps; ++j) {
      const double t = (k - 1) * leg_s + j * ramp * leg_s / steps;
      if (t <= seconds) wps.push_back({t, from + (p - from) * (static_cast<double>(j) / steps)});
    }
    const double t_end = steps > 1 ? (k - 1) * leg_s + ramp * leg_s : k * leg_s;
    if (t_end <= seconds) wps.push_back({t_end, p});
    from = p;
  }
  return wps;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace auger;
  std::string out_path, truth_path, course_path, drive = "square", terrain, screws = "fil", field_path;
  std::string model_path = AUGER_DEFAULT_MODEL, elf = AUGER_DEFAULT_ELF;
  double seconds = 240, blocking_rpm = -1, course_m = 0.5;
  std::uint64_t seed = 1;
  bool online_apply = false, effect_feedforward = false;
  double online_slow_rpm = 2.0;
  double incline_pitch_rad = 0, incline_roll_rad = 0;
  int threads = 1;  // one thread is faster here: the modules and the robot exchange every 1 ms
  sim::CameraParams camera;
  Args args;
  if (const int rc = kCli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
  if (!args.positional.empty()) {
    std::fprintf(stderr, "auger-sim-drive: unknown option '%s'\n", args.positional[0].c_str());
    usage(stderr);
    return 2;
  }
  for (const auto& [a, value] : args.options) {  // in order: the last of a repeated option wins
    auto val = [&value = value] { return value.c_str(); };
    if (a == "--out") out_path = val();
    else if (a == "--truth-out") truth_path = val();
    else if (a == "--course-out") course_path = val();
    else if (a == "--drive") drive = val();
    else if (a == "--terrain") terrain = val();
    else if (a == "--field") field_path = val();
    else if (a == "--course-m") course_m = number("--course-m", val());
    else if (a == "--screws") screws = val();
    else if (a == "--model") model_path = val();
    else if (a == "--elf") elf = val();
    else if (a == "--seconds") seconds = number("--seconds", val());
    else if (a == "--seed") seed = static_cast<std::uint64_t>(number("--seed", val()));
    else if (a == "--blocking-rpm") blocking_rpm = number("--blocking-rpm", val());
    else if (a == "--threads") threads = static_cast<int>(number("--threads", val()));
    else if (a == "--camera-corr-s") camera.noise_corr_s = number("--camera-corr-s", val());
    else if (a == "--camera-latency-s") camera.latency_s = number("--camera-latency-s", val());
    else if (a == "--online-apply") online_apply = true;
    else if (a == "--effect-feedforward") effect_feedforward = true;
    else if (a == "--online-slow-screw-rpm") online_slow_rpm = number("--online-slow-screw-rpm", val());
    else if (a == "--incline-pitch-rad") incline_pitch_rad = number("--incline-pitch-rad", val());
    else if (a == "--incline-roll-rad") incline_roll_rad = number("--incline-roll-rad", val());
  }
  if ((out_path.empty() && course_path.empty()) || (drive == "manual" && !course_path.empty()) || !(seconds > 0) || !(course_m > 0) || (drive != "square" && drive != "diagonal" && drive != "manual") ||
      (screws != "fil" && screws != "ideal") || threads < 1) {
    usage(stderr);
    return 2;
  }
  try {
    const ModelFile file = load_model_file(model_path);
    // Each zone's blocking: the patch's own, else --blocking-rpm, else 1.5 rpm on sand.
    std::shared_ptr<const sim::Field> field;
    if (!field_path.empty()) field = sim::load_field_for_run(field_path, file, blocking_rpm, terrain);
    if (terrain.empty()) terrain = "sand";
    Model m = build_model(file, terrain);  // with --online-apply the controller's, updated in place
    if (!course_path.empty()) {
      // The same course for augerd (`auger cmd follow`, scripts/demo.sh): held at the start
      // until the first waypoint.
      std::ofstream c(course_path);
      c << "t_s,x_m,y_m,psi_rad\n0,0,0,0\n";
      char line[128];
      for (const Waypoint& w : course(drive, course_m, seconds, m)) {
        std::snprintf(line, sizeof line, "%.3f,%.4f,%.4f,%.4f\n", w.t_s, w.eta_p[0], w.eta_p[1], w.eta_p[2]);
        c << line;
      }
      c.close();
      if (!c) {
        std::fprintf(stderr, "auger-sim-drive: cannot write %s\n", course_path.c_str());
        return 1;
      }
      if (out_path.empty()) return 0;
    }
    ControllerConfig cc = controller_config(file, terrain);
    // As the demo configures augerd (scripts/demo.sh): the null-space allocator keeps every screw
    // above the blocking threshold once it engages.
    cc.allocator.kind = AllocatorKind::null_space;
    cc.allocator.omega_min_rpm = 3.0;
    cc.allocator.engage_rpm = 1.5;
    cc.gamma_per_s = Vec3::Constant(0.2);
    cc.effect_feedforward = effect_feedforward;
    Controller controller(m, cc);
    sim::TruthParams tp;  // the physical robot: Coriolis terms, the real lever arms
    if (blocking_rpm < 0) blocking_rpm = terrain == "sand" ? 1.5 : 0.0;
    tp.blocking.on = blocking_rpm > 0;
    tp.blocking.omega_block_rpm = blocking_rpm;
    tp.field = field;
    tp.incline.on = incline_pitch_rad != 0 || incline_roll_rad != 0;
    tp.incline.pitch_rad = incline_pitch_rad;
    tp.incline.roll_rad = incline_roll_rad;
    sim::SchedulerConfig sc;
    sc.mode = screws == "fil" ? sim::ScrewMode::fil : sim::ScrewMode::ideal;
    sc.elf_path = elf;
    sc.threads = threads;
    sc.seed = seed;
    sc.terrain = terrain;
    sc.camera = camera;
    sim::Scheduler s(m, tp, sc);
    std::ofstream log(out_path);
    if (!log) {
      std::fprintf(stderr, "auger-sim-drive: cannot write %s\n", out_path.c_str());
      return 1;
    }
    s.set_log(&log);
    s.set_keep_history(false);
    // The truth, streamed row by row (an hour's run is not held in memory).
    std::ofstream truth_file;
    std::unique_ptr<CsvLogWriter> truth;
    const sim::Field ground = field ? *field : sim::uniform_field(file, terrain);
    std::vector<double> row;
    if (!truth_path.empty()) {
      truth_file.open(truth_path);
      if (!truth_file) {
        std::fprintf(stderr, "auger-sim-drive: cannot write %s\n", truth_path.c_str());
        return 1;
      }
      std::vector<std::string> cols{"t_s", "x_m", "y_m", "psi_rad"};
      for (const auto& c : sim::ground_columns()) cols.push_back(c);
      truth = std::make_unique<CsvLogWriter>(
          truth_file,
          std::vector<std::pair<std::string, std::string>>{{"format", "auger-sim-truth v1"},
                                                           {"field", field ? field->path : ground.path},
                                                           {"terrain_ids", sim::terrain_ids_metadata(ground)}},
          cols);
      s.set_tick_sink([&](const sim::TickRecord& h) {
        sim::ground_values(ground, h.zone, h.contact_zone, row);
        row.insert(row.begin(), {h.t_s, h.eta_true[0], h.eta_true[1], h.eta_true[2]});
        truth->write_row(row.data(), row.size());
      });
    }
    // augerd's [online] with apply (host/augerd/online_link.cpp), in lock-step: the kinematic
    // velocity from this period's camera and IMU, the screw speeds (the true ones; augerd has the
    // modules' measured), the identified terrain and online effect parameters written into the
    // controller's model.
    std::unique_ptr<OnlineEstimator> online;
    KinematicVelocity kin;
    if (online_apply) {
      OnlineConfig oc;
      oc.enabled = true;
      oc.velocity_sd = Vec3(0.012, 0.012, 0.01);
      oc.drag_prior_rel_sd = 0.01;
      oc.slow_screw_rpm = online_slow_rpm;
      oc.cusum_threshold = 16;
      // The model file's effect parameters marked online are estimated with the terrain; the
      // estimator reads the heading (a slope's force turns with it): the IMU's.
      online = std::make_unique<OnlineEstimator>(m, oc, online_effect_params(file, EffectRegistry::builtin()));
      s.set_sensor_sink([&](double, const sim::ImuReading* imu, const sim::PoseReading* pose) {
        const SensorInput in = sim::sensor_input(*imu, pose);
        online->step(s.omega_true_rpm(), kin.step(in, sc.control_period_s), sc.control_period_s,
                     Vec3(0, 0, imu->psi_rad));
        if (online->applied_changed()) {
          set_terrain_parameters(m, online->control_parameters());
          set_effect_parameters(m, online->effects(), online->control_effect_parameters());
        }
      });
    }
    const double boot_s = 0.1;
    if (drive == "manual") {
      Joystick stick(seed);
      s.set_command_source([&](double t_s, Vec4& cmd) {
        if (t_s < boot_s) return false;
        // What augerd sends in mode vel (augerd's contract: eq. (4), scaled to 22 rpm as a whole).
        daemon::MotionInput vel;
        vel.mode = daemon::Mode::vel;
        vel.vel = stick.at(t_s, sc.control_period_s);
        const std::array<double, 4> rpm = daemon::mode_setpoints(vel, {}, m, 22.0);
        cmd = Vec4(rpm[0], rpm[1], rpm[2], rpm[3]);
        return true;
      });
    } else {
      s.set_controller(&controller);
      s.run_until(boot_s);
      controller.set_waypoints(course(drive, course_m, seconds, m));
      controller.set_enabled(true);
    }
    s.run_until(seconds);
    if (online)
      std::fprintf(stderr, "auger-sim-drive: [online] apply: %llu changes detected, sigma_long used at the end %.3f N/rpm%s\n",
                   static_cast<unsigned long long>(online->changes()), online->control_parameters()[kSigmaLong],
                   online->fallback().empty() ? "" : (", fallback: " + online->fallback()).c_str());
    for (int k = 0; online && k < online->estimate().effects; ++k)
      std::fprintf(stderr, "auger-sim-drive: [online] %s %.4g +- %.2g %s%s, used at the end %.4g %s\n",
                   online->effects()[std::size_t(k)].name.c_str(), online->estimate().effect_value[k],
                   online->estimate().effect_sd[k], online->effects()[std::size_t(k)].unit.c_str(),
                   online->estimate().effect_informed[k] > 0 ? "" : " (not informed)",
                   online->control_effect_parameters()[k], online->effects()[std::size_t(k)].unit.c_str());
    log.close();
    if (!log) {
      std::fprintf(stderr, "auger-sim-drive: writing %s failed\n", out_path.c_str());
      return 1;
    }
    if (truth) {
      truth_file.close();
      if (!truth_file) {
        std::fprintf(stderr, "auger-sim-drive: writing %s failed\n", truth_path.c_str());
        return 1;
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger-sim-drive: %s\n", e.what());
    return 1;
  }
  return 0;
}

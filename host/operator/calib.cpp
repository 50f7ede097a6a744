// auger calib: commissioning of the four modules (docs/operator.md).
//  * Per module, directly on the serial ports (augerd not running): spin the screw alone
//    slowly and compare the robot's motion with what the model predicts for that screw
//    (eq. (4) inverted: kinematic_body_velocity), from the IMU yaw rate and the camera pose
//    when a sensor feed is connected to --sensors (the line protocol of augerd's sensors
//    socket), else by asking the operator; a wrong sign is fixed by writing dir_sign through
//    the CONFIG frame. With --turns N: spin until the module has counted N turns, ask the
//    operator how many were counted on the marked screw, report the counts and the implied
//    counts per revolution, and write it.
//  * --check-motion, through augerd: +u, +v and +r each commanded briefly; the pose must move
//    forward, left and counter-clockwise (docs/model-notes.md frames, REP-103).
#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "auger/model_file.hpp"
#include "augerd_client.hpp"
#include "common.hpp"
#include "daemon_lines.hpp"
#include "module_adapter.hpp"
#include "module_link.hpp"
#include "operator.hpp"
#include "status.hpp"

namespace auger::op {
namespace {

const CommandLine& calib_cli() {
  static const CommandLine cli{
      "auger calib",
      "--ports P0,P1,P2,P3 --model MODEL_TOML [OPTIONS] | --check-motion [OPTIONS]",
      "Direction signs (and with --turns, counts per revolution) of each module, on the serial\n"
      "ports with augerd stopped; the robot must be free to move a little. Fixes are written\n"
      "through the CONFIG frame unless --dry-run. --check-motion: through augerd, checks that +u,\n"
      "+v and +r move the robot forward, left and counter-clockwise.\n",
      {{"--ports", "P0,P1,P2,P3", "the modules' serial ports, any order"},
       {"--model", "MODEL_TOML", "the robot's model file (the motion each screw should cause)"},
       {"--terrain", "NAME", "the model's terrain (default sand)"},
       {"--sensors", "PATH", "listen there for IMU/camera lines (augerd's sensors protocol); else ask"},
       {"--modules", "LIST", "the modules to check (default 0,1,2,3)"},
       {"--rpm", "X", "screw speed while checking (default 8 rpm; 0 .. 15)"},
       {"--seconds", "S", "spin time per module (default 2.5 s, --check-motion 2 s; 0.5 .. 20)"},
       {"--turns", "N", "also count N screw turns to check counts per revolution (0 .. 20)"},
       {"--dry-run", "", "report what is wrong, write nothing"},
       {"--check-motion", "", "the commissioning check through augerd"},
       {"--socket", "PATH", std::string("with --check-motion: augerd's commands socket (default ") +
                               io::kDefaultCommandsSocket + ")"},
       {"--speed", "MPS", "with --check-motion: the body speed used (default 0.03 m/s)"}},
      "Exit 0: all was right; 1: something was wrong (and fixed, or with --check-motion: the motion\n"
      "is wrong); 2: bad usage; 3: a module or augerd not reached.\n"};
  return cli;
}

void calib_usage(std::FILE* f) { calib_cli().print_usage(f); }

std::vector<std::string> split_commas(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

// A listening socket speaking augerd's sensors protocol, while augerd is stopped.
class SensorFeed {
 public:
  explicit SensorFeed(const std::string& path) : path_(path) {
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path.size() >= sizeof addr.sun_path) throw std::runtime_error("sensor socket path too long: " + path);
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    ::unlink(path.c_str());
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(fd_, 4) != 0)
      throw std::runtime_error("cannot listen on " + path + ": " + std::strerror(errno) + " (augerd running?)");
  }
  ~SensorFeed() {
    for (int c : clients_) ::close(c);
    if (fd_ >= 0) ::close(fd_), ::unlink(path_.c_str());
  }
  // Reads what arrived; the latest IMU yaw rate and camera pose are kept, with counts.
  void poll_once() {
    for (int c; (c = ::accept4(fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC)) >= 0;) clients_.push_back(c);
    char buf[4096];
    for (std::size_t i = 0; i < clients_.size(); ++i) {
      const ssize_t n = ::recv(clients_[i], buf, sizeof buf, 0);
      if (n > 0) in_.append(buf, std::size_t(n));
    }
    std::size_t nl;
    while ((nl = in_.find('\n')) != std::string::npos) {
      daemon::SensorMessage m;
      if (daemon::parse_sensor(in_.substr(0, nl), m).empty()) {
        if (m.kind == daemon::SensorKind::imu) {
          r_sum_ += m.imu_r_radps;
          ++r_n_;
        } else {
          pose_ = Vec3(m.x_m, m.y_m, m.psi_rad);
          if (!first_pose_) first_pose_ = pose_;
        }
      }
      in_.erase(0, nl + 1);
    }
  }
  void start_window() {
    r_sum_ = 0, r_n_ = 0;
    first_pose_.reset();
    pose_.reset();
  }
  int imu_count() const { return r_n_; }
  double mean_r_radps() const { return r_n_ ? r_sum_ / r_n_ : NAN; }
  std::optional<Vec3> displacement() const {
    if (!first_pose_ || !pose_) return std::nullopt;
    return Vec3(*pose_ - *first_pose_);
  }
  std::optional<Vec3> first_pose() const { return first_pose_; }

 private:
  std::string path_;
  int fd_ = -1;
  std::vector<int> clients_;
  std::string in_;
  double r_sum_ = 0;
  int r_n_ = 0;
  std::optional<Vec3> first_pose_, pose_;
};

bool ask_yes(const std::string& question) {
  std::printf("%s [y/n] ", question.c_str());
  std::fflush(stdout);
  std::string a;
  if (!std::getline(std::cin, a)) throw std::runtime_error("no answer on standard input");
  return !a.empty() && (a[0] == 'y' || a[0] == 'Y');
}

std::string motion_text(const Vec3& zeta) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "u=%+.3f m/s (forward), v=%+.3f m/s (left), r=%+.3f rad/s (counter-clockwise)",
                zeta[0], zeta[1], zeta[2]);
  return buf;
}

struct Spinner {
  io::ModuleLink& link;
  uint16_t seq = 0;
  io::ModuleTelemetry tm;  // the latest frame
  void send(double rpm, bool enable, bool clear = false) {
    uint8_t buf[PROTO_MAX_FRAME];
    link.send_frame(buf, io::encode_setpoint(seq++, rpm, enable, clear, buf));
  }
  void pump() {
    std::vector<proto_frame_t> frames;
    link.pump(frames);
    for (const auto& f : frames) {
      proto_telemetry_t frame;
      if (proto_decode_telemetry(&f, &frame)) tm.take(frame);
    }
    if (tm.received && (tm.frame.status & PROTO_F_MASK))
      throw std::runtime_error(link.port() + ": module reports " + fault_bits_text(tm.frame.status));
  }
  // Spins at rpm for seconds (or until stop() says so), feeding sensors meanwhile.
  template <class Stop>
  void spin(double rpm, double seconds, SensorFeed* feed, double window_from_s, Stop stop) {
    const double t0 = now_s();
    bool window = false;
    for (double next = t0; now_s() - t0 < seconds; next += 0.01) {
      send(rpm, true, seq == 0);
      pump();
      if (feed) {
        if (!window && now_s() - t0 >= window_from_s) feed->start_window(), window = true;
        feed->poll_once();
      }
      if (stop()) break;
      sleep_s(next + 0.01 - now_s());
    }
  }
  void off() {
    for (int i = 0; i < 30; ++i) {  // 0.3 s at 0 without ENABLE: the motor off before a CONFIG
      send(0, false);
      pump();
      sleep_s(0.01);
    }
  }
};

int check_motion(const std::string& socket, double speed_mps, double seconds) {
  io::AugerdClient c(socket);
  if (c.request("enable") != "ok") throw std::runtime_error("augerd refused enable");
  struct Dof {
    const char* name;
    Vec3 cmd;
    const char* expect;
  };
  const Dof dofs[] = {{"+u", Vec3(speed_mps, 0, 0), "forward (+x body)"},
                      {"+v", Vec3(0, speed_mps, 0), "left (+y body)"},
                      {"+r", Vec3(0, 0, 4 * speed_mps), "counter-clockwise (+psi)"}};
  int wrong = 0;
  for (const auto& d : dofs) {
    auto pose = [&] {
      daemon::Status st;
      if (const std::string bad = daemon::parse_status(c.request("status all"), st); !bad.empty())
        throw std::runtime_error("augerd's status all: " + bad);
      // The camera when it is fresh (the truth the estimate is fused from), else the estimate.
      if (st.pose_age_s < 0.5) return Vec3(st.cam_x_m, st.cam_y_m, st.cam_psi_rad);
      return Vec3(st.x_m, st.y_m, st.psi_rad);
    };
    const Vec3 p0 = pose();
    char line[96];
    std::snprintf(line, sizeof line, "vel %.4f %.4f %.4f", d.cmd[0], d.cmd[1], d.cmd[2]);
    const double t0 = now_s();
    while (now_s() - t0 < seconds) {
      const std::string a = c.request(line);
      if (a != "ok") throw std::runtime_error("augerd: " + a);
      sleep_s(0.1);
    }
    sleep_s(0.7);  // the dead-man stops the screws; the camera catches up
    const Vec3 p1 = pose();
    // World displacement into the body frame at the start heading (eq. (1)'s rotation).
    const double c0 = std::cos(p0[2]), s0 = std::sin(p0[2]);
    const Vec3 db(c0 * (p1[0] - p0[0]) + s0 * (p1[1] - p0[1]), -s0 * (p1[0] - p0[0]) + c0 * (p1[1] - p0[1]),
                  wrap_angle(p1[2] - p0[2]));
    const int k = d.cmd[0] != 0 ? 0 : d.cmd[1] != 0 ? 1 : 2;
    const bool ok = db[k] > 0 && std::fabs(db[k]) >= 0.5 * std::fabs(k == 2 ? 0.0 : db[1 - (k == 1)]);
    std::printf("%s: moved dx_body=%+.3f m dy_body=%+.3f m dpsi=%+.3f rad; expected %s: %s\n", d.name, db[0], db[1],
                db[2], d.expect, ok ? "ok" : "WRONG");
    if (!ok) ++wrong;
  }
  c.request("stop");
  return wrong ? 1 : 0;
}

}  // namespace

int run_calib(int argc, char** argv) {
  std::string ports_arg, model_path, terrain = "sand", sensors, socket = io::kDefaultCommandsSocket, modules_arg = "0,1,2,3";
  double rpm = 8, seconds = 2.5, turns = 0, speed_mps = 0.03;
  bool dry = false, motion = false, seconds_given = false;
  try {
    Args a;
    if (const int rc = calib_cli().parse_or_answer(argc, argv, a); rc >= 0) return rc;
    if (!a.positional.empty()) throw UsageError("unknown argument " + a.positional[0]);
    const char* me = "auger calib";
    if (!a.number(me, "--rpm", rpm, rpm) || !a.number(me, "--seconds", seconds, seconds) ||
        !a.number(me, "--turns", turns, turns) || !a.number(me, "--speed", speed_mps, speed_mps))
      return calib_usage(stderr), 2;
    seconds_given = a.has("--seconds");
    ports_arg = a.get("--ports");
    model_path = a.get("--model");
    terrain = a.get("--terrain", terrain);
    sensors = a.get("--sensors");
    socket = a.get("--socket", socket);
    modules_arg = a.get("--modules", modules_arg);
    dry = a.has("--dry-run");
    motion = a.has("--check-motion");
    if (motion) {
      if (!seconds_given) seconds = 2.0;
      try {
        return check_motion(socket, speed_mps, seconds);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "auger calib: %s\n", e.what());
        return 3;
      }
    }
    if (ports_arg.empty()) throw UsageError("--ports P0,P1,P2,P3 is required (or --check-motion)");
    if (model_path.empty()) throw UsageError("--model is required (the robot's model file)");
    if (!(rpm > 0 && rpm <= 15)) throw UsageError("--rpm must be within 0 .. 15 (slow)");
    if (!(seconds >= 0.5 && seconds <= 20)) throw UsageError("--seconds must be within 0.5 .. 20");
    if (turns < 0 || turns > 20) throw UsageError("--turns must be within 0 .. 20");
  } catch (const UsageError& e) {
    std::fprintf(stderr, "auger calib: %s\n", e.what());
    calib_usage(stderr);
    return 2;
  }
  try {
    const Model model = build_model(load_model_file(model_path), terrain);
    std::vector<int> wanted;
    for (const auto& m : split_commas(modules_arg)) {
      const double x = parse_number("--modules", m);
      if (x != 0 && x != 1 && x != 2 && x != 3) throw UsageError("--modules: '" + m + "' is not 0..3");
      wanted.push_back(int(x));
    }
    std::array<std::unique_ptr<io::ModuleLink>, 4> by_id;
    for (const auto& p : split_commas(ports_arg)) {
      auto link = std::make_unique<io::ModuleLink>(p);
      const proto_identity_t id = link->identify(4.0);
      if (id.module_id > 3) throw std::runtime_error(p + ": module id " + std::to_string(id.module_id) + " is not 0..3");
      if (by_id[id.module_id]) throw std::runtime_error(p + ": module id " + std::to_string(id.module_id) + " twice");
      by_id[id.module_id] = std::move(link);
    }
    std::unique_ptr<SensorFeed> feed;
    if (!sensors.empty()) feed = std::make_unique<SensorFeed>(sensors);
    int fixed = 0;
    for (int k : wanted) {
      if (!by_id[std::size_t(k)]) throw std::runtime_error("module " + std::to_string(k) + " is on none of the ports");
      io::ModuleLink& link = *by_id[std::size_t(k)];
      proto_config_t cfg = link.read_config();
      Spinner sp{link, 0, {}};
      Vec4 w = Vec4::Zero();
      w[k] = rpm;
      const Vec3 zeta = kinematic_body_velocity(model, w);  // eq. (4) inverted: this screw alone
      std::printf("module %d (%s): dir_sign %+d, counts_per_rev %.2f; spinning at %+.1f rpm for %.1f s\n", k,
                  link.port().c_str(), cfg.dir_sign, cfg.counts_per_rev_x100 / 100.0, rpm, seconds);
      std::printf("  expected motion (model): %s\n", motion_text(zeta).c_str());
      sp.spin(rpm, seconds, feed.get(), 0.4 * seconds, [] { return false; });
      const double omega_rpm = sp.tm.omega_rpm();
      // Measured sign: the IMU yaw rate when the model expects a clear rotation, else the camera.
      int verdict = 0;  // +1 right, -1 wrong, 0 undecided
      if (feed && feed->imu_count() >= 5 && std::fabs(zeta[2]) > 0.002) {
        const double r = feed->mean_r_radps();
        std::printf("  IMU: mean yaw rate %+.4f rad/s over %d samples (expected %+.4f)\n", r, feed->imu_count(), zeta[2]);
        if (std::fabs(r) > 0.25 * std::fabs(zeta[2])) verdict = r * zeta[2] > 0 ? 1 : -1;
      }
      if (verdict == 0 && feed && feed->displacement()) {
        const Vec3 d = *feed->displacement();
        const double psi = (*feed->first_pose())[2];
        const Vec3 db(std::cos(psi) * d[0] + std::sin(psi) * d[1], -std::sin(psi) * d[0] + std::cos(psi) * d[1], d[2]);
        const double along = db[0] * zeta[0] + db[1] * zeta[1];
        std::printf("  camera: moved %+.3f m, %+.3f m (body frame)\n", db[0], db[1]);
        if (std::hypot(db[0], db[1]) > 0.005) verdict = along > 0 ? 1 : -1;
      }
      if (verdict == 0) verdict = ask_yes("  Did the robot move as expected (" + motion_text(zeta) + ")?") ? 1 : -1;
      // Back to about where it was, so that the next module starts from the same place.
      sp.spin(-rpm, seconds, nullptr, 0, [] { return false; });
      sp.off();
      if (omega_rpm * rpm <= 0) std::printf("  module reported %+.2f rpm: encoder or motor wiring?\n", omega_rpm);
      if (verdict > 0) {
        std::printf("  direction: ok\n");
      } else {
        std::printf("  direction: WRONG (dir_sign %+d)", cfg.dir_sign);
        ++fixed;
        if (dry) {
          std::printf("; --dry-run: not written\n");
        } else {
          cfg.dir_sign = int8_t(-cfg.dir_sign);
          cfg = link.write_config(cfg);
          std::printf("; wrote dir_sign %+d\n", cfg.dir_sign);
        }
      }
      if (turns > 0) {
        const double cpr = cfg.counts_per_rev_x100 / 100.0;
        sp.pump();
        const int32_t start = sp.tm.frame.position_counts;
        const double target = turns * cpr;
        std::printf("  counts per revolution: spinning %.1f turns by the module's count (%.0f counts)\n", turns, target);
        // The last 20 % slowly, so that the screw stops close to the mark (it coasts).
        sp.spin(rpm, 120.0, nullptr, 0, [&] { return std::fabs(double(sp.tm.frame.position_counts - start)) >= 0.8 * target; });
        sp.spin(std::min(rpm, 1.5), 120.0, nullptr, 0,
                [&] { return std::fabs(double(sp.tm.frame.position_counts - start)) >= target; });
        sp.off();
        const double counted = double(sp.tm.frame.position_counts - start);
        std::printf("  How many turns did the marked screw make? ");
        std::fflush(stdout);
        std::string a;
        if (!std::getline(std::cin, a)) throw std::runtime_error("no answer on standard input");
        const double seen = parse_number("turns", a);
        if (!(seen > 0)) throw UsageError("turns counted must be > 0, got '" + a + "'");
        const double implied = std::fabs(counted) / seen;
        std::printf("\n  measured %.0f counts over %.2f turns: %.2f counts/rev (configured %.2f)\n", counted, seen,
                    implied, cpr);
        if (std::fabs(implied - cpr) > 0.01 * cpr) {
          ++fixed;
          if (dry) {
            std::printf("  counts_per_rev: WRONG; --dry-run: not written\n");
          } else {
            cfg.counts_per_rev_x100 = uint32_t(std::lround(implied * 100));
            cfg = link.write_config(cfg);
            std::printf("  counts_per_rev: WRONG; wrote %.2f\n", cfg.counts_per_rev_x100 / 100.0);
          }
        } else {
          std::printf("  counts_per_rev: ok\n");
        }
      }
    }
    std::printf("%s\n", fixed ? "calibration changed settings (or would have, --dry-run)" : "all modules ok");
    return fixed ? 1 : 0;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "auger calib: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger calib: %s\n", e.what());
    return 3;
  }
}

}  // namespace auger::op

// auger monitor: a live terminal view of augerd (`status all` polled every --period seconds):
// per module speed and setpoint, current, voltage, PWM, status and fault bits by name, link
// error counters; the estimated pose and reference, the sensors, the loop period and jitter;
// with augerd's [online], the believed terrain and the estimate.
// Faults in reverse video (and red where the terminal has colours). Plain ncurses: works over
// ssh, no mouse; resizes; `q` quits. docs/operator.md.
#include <curses.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "auger/args.hpp"
#include "augerd_client.hpp"
#include "common.hpp"
#include "operator.hpp"

namespace auger::op {
namespace {

using Status = std::map<std::string, std::string>;

std::string field(const Status& kv, const std::string& key, const char* fallback = "?") {
  const auto it = kv.find(key);
  return it == kv.end() ? fallback : it->second;
}

void draw(const Status& kv, const std::string& socket, const std::string& error, bool colour) {
  erase();
  int row = 0;
  const int highlight = A_REVERSE | A_BOLD | (colour ? COLOR_PAIR(1) : 0);
  mvprintw(row++, 0, "auger monitor  %s   (q quits)", socket.c_str());
  if (!error.empty()) {
    attron(highlight);
    mvprintw(row++, 0, "%s", error.c_str());
    attroff(highlight);
    refresh();
    return;
  }
  const std::string fault = field(kv, "fault");
  mvprintw(row, 0, "t=%ss  enabled=%s  mode=%s  arrived=%s  fault=", field(kv, "t_s").c_str(),
           field(kv, "enabled").c_str(), field(kv, "mode").c_str(), field(kv, "arrived", "-").c_str());
  if (fault != "none") attron(highlight);
  printw("%s", fault.c_str());
  if (fault != "none") attroff(highlight);
  ++row;
  const double dt_ms = 1e3 * io::status_number(kv, "loop_dt_s");
  const double jit_ms = 1e3 * io::status_number(kv, "loop_jitter_max_s");
  mvprintw(row++, 0, "loop period %.2f ms, jitter (max |dt-period|, last 1 s) %.2f ms", dt_ms, jit_ms);
  mvprintw(row++, 0, "pose estimate x=%s m  y=%s m  psi=%s rad    reference x=%s y=%s psi=%s",
           field(kv, "x_m").c_str(), field(kv, "y_m").c_str(), field(kv, "psi_rad").c_str(),
           field(kv, "xd_m").c_str(), field(kv, "yd_m").c_str(), field(kv, "psid_rad").c_str());
  const double imu_age = io::status_number(kv, "imu_age_s"), cam_age = io::status_number(kv, "pose_age_s");
  if (std::isfinite(imu_age))
    mvprintw(row++, 0, "imu psi=%s rad r=%s rad/s (%.2f s ago)", field(kv, "imu_psi_rad").c_str(),
             field(kv, "imu_r_radps").c_str(), imu_age);
  else
    mvprintw(row++, 0, "imu: none received");
  if (std::isfinite(cam_age))
    mvprintw(row++, 0, "camera x=%s y=%s psi=%s (%.2f s ago)", field(kv, "cam_x_m").c_str(),
             field(kv, "cam_y_m").c_str(), field(kv, "cam_psi_rad").c_str(), cam_age);
  else
    mvprintw(row++, 0, "camera: none received");
  ++row;
  mvprintw(row++, 0, "%-3s %-22s %8s %8s %7s %7s %7s %-6s %-12s %-16s %s", "id", "port", "omega", "setpt",
           "curr_A", "volt_V", "pwm", "status", "state", "faults", "link errors (mod rx, enc, host crc/hdr/skip)");
  for (int i = 0; i < 4; ++i) {
    const std::string m = "m" + std::to_string(i) + "_";
    const std::string faults = field(kv, m + "faults");
    const bool lost = field(kv, m + "lost") == "1";
    const bool named = fault.rfind(std::to_string(i) + ":", 0) == 0;  // the module augerd stopped for
    const bool bad = lost || (faults != "none" && faults != "?") || named;
    const uint16_t status = uint16_t(std::strtoul(field(kv, m + "status", "0").c_str(), nullptr, 16));
    if (bad) attron(highlight);
    std::string port = field(kv, m + "port");
    if (port.size() > 22) port = "..." + port.substr(port.size() - 19);
    mvprintw(row++, 0, "%-3d %-22s %8s %8s %7s %7s %7s %-6s %-12s %-16s %s %s %s/%s/%s%s", i, port.c_str(),
             field(kv, m + "omega_rpm").c_str(), field(kv, m + "cmd_rpm").c_str(), field(kv, m + "current_a").c_str(),
             field(kv, m + "voltage_v").c_str(), field(kv, m + "pwm").c_str(), field(kv, m + "status").c_str() + 2,
             state_bits_text(status).c_str(), faults.c_str(), field(kv, m + "rx_errors").c_str(),
             field(kv, m + "encoder_errors").c_str(), field(kv, m + "host_crc_errors").c_str(),
             field(kv, m + "host_header_errors").c_str(), field(kv, m + "host_bytes_skipped").c_str(),
             lost ? "  LOST" : "");
    if (bad) attroff(highlight);
  }
  if (kv.count("online_terrain")) {
    // augerd's [online] (docs/daemon.md "Online identification"): the terrain the estimate is
    // closest to, the estimate with its SDs, the detector; fallback highlighted like a fault.
    mvprintw(row++, 0, "ground (online): %s  sigma_long=%s+-%s sigma_lat=%s+-%s N/rpm  D_x=%s+-%s D_y=%s+-%s N/(m/s)",
             field(kv, "online_terrain").c_str(), field(kv, "on_sigma_long").c_str(),
             field(kv, "on_sd_sigma_long").c_str(), field(kv, "on_sigma_lat").c_str(),
             field(kv, "on_sd_sigma_lat").c_str(), field(kv, "on_D_x").c_str(), field(kv, "on_sd_D_x").c_str(),
             field(kv, "on_D_y").c_str(), field(kv, "on_sd_D_y").c_str());
    const bool fallback = field(kv, "on_fallback") == "1";
    mvprintw(row, 0, "  CUSUM %s, %s changes detected", field(kv, "on_cusum").c_str(), field(kv, "on_changes").c_str());
    if (fallback) attron(highlight);
    printw("%s", fallback ? "  FALLBACK to the configured terrain" : "");
    if (fallback) attroff(highlight);
    ++row;
  }
  ++row;
  mvprintw(row++, 0, "omega/setpt rpm; state: EN enabled, SP setpoint fresh, DEF defaults, SAT duty-limited, EE eeprom busy");
  refresh();
}

}  // namespace

int run_monitor(int argc, char** argv) {
  std::string socket = io::kDefaultCommandsSocket;
  double period_s = 0.1;
  try {
    const CommandLine cli{
        "auger monitor", "[OPTIONS]", "Live view of augerd's modules, pose and loop (ncurses); q quits.\n",
        {socket_option(),
         {"--period", "S", "refresh period (default 0.1 s; 0.02 .. 10 s)"}},
        "Exit 0: quit; 2: bad usage; 3: augerd not reached.\n"};
    Args a;
    if (const int rc = cli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
    if (!a.positional.empty()) throw UsageError("unknown argument " + a.positional[0]);
    socket = a.get("--socket", socket);
    if (!a.number("auger monitor", "--period", period_s, period_s)) return 2;
    if (!(period_s >= 0.02 && period_s <= 10)) throw UsageError("--period must be within 0.02 .. 10 s");
  } catch (const UsageError& e) {
    std::fprintf(stderr, "auger monitor: %s\n", e.what());
    return 2;
  }
  std::unique_ptr<io::AugerdClient> c;
  try {
    c = std::make_unique<io::AugerdClient>(socket);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger monitor: %s\n", e.what());
    return 3;
  }
  initscr();
  cbreak();
  noecho();
  keypad(stdscr, TRUE);
  curs_set(0);
  const bool colour = has_colors();
  if (colour) {
    start_color();
    init_pair(1, COLOR_RED, COLOR_BLACK);
  }
  timeout(int(period_s * 1000));
  int code = 0;
  std::string error;
  for (;;) {
    Status kv;
    if (c) {
      try {
        kv = io::parse_status(c->request("status all", 2000));
        error.clear();
      } catch (const std::exception& e) {
        error = std::string(e.what()) + "; reconnecting";
        c.reset();
      }
    } else {
      try {
        c = std::make_unique<io::AugerdClient>(socket);
        continue;
      } catch (const std::exception& e) {
        error = std::string("augerd gone: ") + e.what();
      }
    }
    draw(kv, socket, error, colour);
    const int ch = getch();  // waits up to the period; KEY_RESIZE: ncurses has resized stdscr
    if (ch == 'q' || ch == 'Q') break;
  }
  endwin();
  return code;
}

}  // namespace auger::op

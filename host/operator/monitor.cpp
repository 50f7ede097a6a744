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
#include "status.hpp"

namespace auger::op {
namespace {

using daemon::Status;

// A number as augerd's status line writes it (status.cpp), for the columns below.
std::string num(const char* format, double v) {
  char b[32];
  std::snprintf(b, sizeof b, format, v);
  return b;
}

void draw(const Status& st, const std::string& socket, const std::string& error, bool colour) {
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
  const std::string& fault = st.fault;
  mvprintw(row, 0, "t=%.3fs  enabled=%d  mode=%s  arrived=%d  fault=", st.t_s, st.enabled ? 1 : 0, st.mode.c_str(),
           st.arrived ? 1 : 0);
  if (fault != "none") attron(highlight);
  printw("%s", fault.c_str());
  if (fault != "none") attroff(highlight);
  ++row;
  mvprintw(row++, 0, "loop period %.2f ms, jitter (max |dt-period|, last 1 s) %.2f ms", 1e3 * st.loop_dt_s,
           1e3 * st.loop_jitter_max_s);
  mvprintw(row++, 0, "pose estimate x=%.4f m  y=%.4f m  psi=%.4f rad    reference x=%.4f y=%.4f psi=%.4f", st.x_m,
           st.y_m, st.psi_rad, st.xd_m, st.yd_m, st.psid_rad);
  if (std::isfinite(st.imu_age_s))
    mvprintw(row++, 0, "imu psi=%.4f rad r=%.4f rad/s (%.2f s ago)", st.imu_psi_rad, st.imu_r_radps, st.imu_age_s);
  else
    mvprintw(row++, 0, "imu: none received");
  if (std::isfinite(st.pose_age_s))
    mvprintw(row++, 0, "camera x=%.4f y=%.4f psi=%.4f (%.2f s ago)", st.cam_x_m, st.cam_y_m, st.cam_psi_rad,
             st.pose_age_s);
  else
    mvprintw(row++, 0, "camera: none received");
  ++row;
  mvprintw(row++, 0, "%-3s %-22s %8s %8s %7s %7s %7s %-6s %-12s %-16s %s", "id", "port", "omega", "setpt",
           "curr_A", "volt_V", "pwm", "status", "state", "faults", "link errors (mod rx, enc, host crc/hdr/skip)");
  for (int i = 0; i < 4; ++i) {
    const daemon::ModuleStatus& m = st.modules[std::size_t(i)];
    const bool named = fault.rfind(std::to_string(i) + ":", 0) == 0;  // the module augerd stopped for
    const bool bad = m.lost || m.faults != "none" || named;
    if (bad) attron(highlight);
    std::string port = m.port;
    if (port.size() > 22) port = "..." + port.substr(port.size() - 19);
    char status[8];
    std::snprintf(status, sizeof status, "%04x", unsigned(m.status));
    mvprintw(row++, 0, "%-3d %-22s %8s %8s %7s %7s %7s %-6s %-12s %-16s %u %u %u/%u/%u%s", i, port.c_str(),
             num("%.2f", m.omega_rpm).c_str(), num("%.2f", m.cmd_rpm).c_str(), num("%.3f", m.current_a).c_str(),
             num("%.3f", m.voltage_v).c_str(), num("%.4f", m.pwm).c_str(), status, state_bits_text(m.status).c_str(),
             m.faults.c_str(), m.rx_errors, m.encoder_errors, m.host_crc_errors, m.host_header_errors,
             m.host_bytes_skipped, m.lost ? "  LOST" : "");
    if (bad) attroff(highlight);
  }
  if (st.online) {
    // augerd's [online] (docs/daemon.md "Online identification"): the terrain the estimate is
    // closest to, the estimate with its SDs, the detector; fallback highlighted like a fault.
    // With the drag held the name comes from sigma / D and the D shown are the configured ones.
    mvprintw(row++, 0, "ground (online): %s%s  sigma_long=%.4g+-%.2g sigma_lat=%.4g+-%.2g N/rpm  D_x=%.5g+-%.2g D_y=%.5g+-%.2g N/(m/s)%s",
             st.online_terrain.c_str(), st.on_drag_held ? " (by sigma/D)" : "", st.on_sigma_long, st.on_sd_sigma_long,
             st.on_sigma_lat, st.on_sd_sigma_lat, st.on_D_x, st.on_sd_D_x, st.on_D_y, st.on_sd_D_y,
             st.on_drag_held ? " (D held)" : "");
    const bool fallback = st.on_fallback;
    mvprintw(row, 0, "  CUSUM %.3g, %ld changes detected", st.on_cusum, st.on_changes);
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
        const std::string bad = daemon::parse_status(c->request("status all", 2000), kv);
        error = bad.empty() ? "" : "augerd's status all: " + bad;
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

// auger teleop: drive the robot by hand through augerd's `vel` (docs/operator.md). A terminal
// has no key-release events: each key press (and the terminal's auto-repeat while the key is
// held) sends `vel`; when the repeats stop, augerd's own 0.5 s dead-man (vel_timeout_s) stops
// the screws. A joystick (Linux joystick API, /dev/input/js*) when present: the axes give
// u, v, r while button 0 (the dead-man) is held; button 1 enable, button 2 stop.
// Like any other motion, the run is in augerd's log.
#include <curses.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "auger/args.hpp"
#include "augerd_client.hpp"
#include "common.hpp"
#include "joystick.hpp"
#include "operator.hpp"
#include "status.hpp"

namespace auger::op {
namespace {

// Speed steps (+/-): u and v in m/s, r in rad/s. The robot's top speed at 23 rpm is about
// 0.1 m/s on sand (docs/model-notes.md), so the steps stay below that.
constexpr double kSpeedSteps_mps[] = {0.01, 0.02, 0.04, 0.06, 0.08, 0.1};
constexpr double kYawStep_radps_per_mps = 2.0;  // r step in rad/s per m/s of the linear step
constexpr int kSteps = sizeof kSpeedSteps_mps / sizeof kSpeedSteps_mps[0];

}  // namespace

int run_teleop(int argc, char** argv) {
  std::string socket = io::kDefaultCommandsSocket, joystick = "/dev/input/js0";
  try {
    const CommandLine cli{
        "auger teleop", "[OPTIONS]",
        "Drive the robot through augerd by keyboard or joystick.\n"
        "Keys: Up/Down or w/s: u (forward/back); Left/Right or a/d: v (left/right);\n"
        "      z/c: r (turn counter-clockwise/clockwise); +/-: speed step; e: enable;\n"
        "      space: stop (all screws off, disabled); q: quit (stops).\n"
        "Holding a key repeats the command (terminal auto-repeat); releasing it stops the\n"
        "robot through augerd's dead-man within 0.5 s. Joystick: axes 0/1 v/u, axis 3 r while\n"
        "button 0 is held; button 1 enable, button 2 stop.\n",
        {socket_option(),
         {"--joystick", "DEV", "joystick device, used when present (default /dev/input/js0)"}},
        "Exit 0: quit; 2: bad usage; 3: augerd not reached.\n"};
    Args a;
    if (const int rc = cli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
    if (!a.positional.empty()) throw UsageError("unknown argument " + a.positional[0]);
    socket = a.get("--socket", socket);
    joystick = a.get("--joystick", joystick);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "auger teleop: %s\n", e.what());
    return 2;
  }
  std::unique_ptr<io::AugerdClient> c;
  try {
    c = std::make_unique<io::AugerdClient>(socket);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger teleop: %s\n", e.what());
    return 3;
  }
  Joystick js;
  double js_sent_s = 0;
  js.open(joystick);
  initscr();
  cbreak();
  noecho();
  keypad(stdscr, TRUE);
  curs_set(0);
  timeout(50);
  int step = 1;
  std::string last_cmd = "-", last_answer = "-", status_text;
  double status_at_s = 0;
  int code = 0;
  auto send = [&](const std::string& line) {
    try {
      last_cmd = line;
      last_answer = c->request(line, 2000);
    } catch (const std::exception& e) {
      last_answer = e.what();
      code = 3;
    }
  };
  for (;;) {
    const int ch = getch();
    const double lin = kSpeedSteps_mps[step], yaw = kYawStep_radps_per_mps * lin;
    double u = 0, v = 0, r = 0;
    bool move = false;
    switch (ch) {
      case KEY_UP: case 'w': u = lin, move = true; break;
      case KEY_DOWN: case 's': u = -lin, move = true; break;
      case KEY_LEFT: case 'a': v = lin, move = true; break;   // y is to the left (REP-103)
      case KEY_RIGHT: case 'd': v = -lin, move = true; break;
      case 'z': r = yaw, move = true; break;                  // psi counter-clockwise from above
      case 'c': r = -yaw, move = true; break;
      case '+': case '=': step = std::min(step + 1, kSteps - 1); break;
      case '-': step = std::max(step - 1, 0); break;
      case 'e': send("enable"); break;
      case ' ': send("stop"); break;
      default: break;
    }
    if (ch == 'q' || ch == 'Q') {
      send("stop");
      break;
    }
    char line[96];
    if (move) {
      std::snprintf(line, sizeof line, "vel %.4f %.4f %.4f", u, v, r);
      send(line);
    }
    const unsigned pressed = js.poll_events();
    if (pressed & 2u) send("enable");
    if (pressed & 4u) send("stop");
    // Joystick: refresh at 10 Hz while the dead-man button is held; released = no refresh,
    // and augerd's dead-man stops the screws.
    if (js.is_open() && js.button(0) && now_s() - js_sent_s >= 0.1) {
      const double top = kSpeedSteps_mps[kSteps - 1];
      std::snprintf(line, sizeof line, "vel %.4f %.4f %.4f", -js.axis(1) * top, -js.axis(0) * top,
                    -js.axis(3) * kYawStep_radps_per_mps * top);
      send(line);
      js_sent_s = now_s();
    }
    if (now_s() - status_at_s > 0.2) {
      try {
        status_text = c->request("status", 2000);
      } catch (const std::exception& e) {
        status_text = e.what();
      }
      status_at_s = now_s();
    }
    daemon::Status st;
    const bool known = daemon::parse_status(status_text, st).empty();
    // As augerd writes them (status.cpp); "?" while no status has been read.
    auto num = [known](double v) {
      char b[32];
      std::snprintf(b, sizeof b, "%.4f", v);
      return std::string(known ? b : "?");
    };
    erase();
    mvprintw(0, 0, "auger teleop  %s   joystick: %s", socket.c_str(), js.is_open() ? joystick.c_str() : "none");
    mvprintw(2, 0, "speed step %d/%d: u,v %.2f m/s, r %.2f rad/s", step + 1, kSteps, lin, yaw);
    mvprintw(3, 0, "last command: %s -> %s", last_cmd.c_str(), last_answer.c_str());
    mvprintw(5, 0, "mode=%s enabled=%s fault=%s", known ? st.mode.c_str() : "?", known ? (st.enabled ? "1" : "0") : "?",
             known ? st.fault.c_str() : "?");
    mvprintw(6, 0, "pose x=%s m y=%s m psi=%s rad", num(st.x_m).c_str(), num(st.y_m).c_str(), num(st.psi_rad).c_str());
    mvprintw(8, 0, "Up/Down w/s: u   Left/Right a/d: v   z/c: r   +/-: speed   e: enable   space: stop   q: quit");
    mvprintw(9, 0, "Hold a key to keep moving; release: augerd stops the screws within 0.5 s (dead-man).");
    refresh();
  }
  endwin();
  return code;
}

}  // namespace auger::op

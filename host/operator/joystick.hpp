// A gamepad through Linux's joystick interface (linux/joystick.h), for auger teleop. Kept out
// of teleop.cpp: linux/input.h defines KEY_UP & co. as input codes, clashing with curses.h.
#pragma once

#include <string>

namespace auger::op {

class Joystick {
 public:
  Joystick() = default;
  ~Joystick();
  Joystick(const Joystick&) = delete;
  Joystick& operator=(const Joystick&) = delete;
  bool open(const std::string& dev);  // false if absent (no joystick: the keyboard only)
  bool is_open() const { return fd_ >= 0; }
  // Reads every pending event; returns the buttons newly pressed as a bit mask.
  unsigned poll_events();
  double axis(int i) const { return axis_[i]; }  // -1 .. 1
  bool button(int i) const { return button_[i]; }

 private:
  int fd_ = -1;
  double axis_[8] = {};
  bool button_[8] = {};
};

}  // namespace auger::op

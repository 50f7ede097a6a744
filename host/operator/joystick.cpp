#include "joystick.hpp"

#include <fcntl.h>
#include <linux/joystick.h>
#include <unistd.h>

namespace auger::op {

Joystick::~Joystick() {
  if (fd_ >= 0) ::close(fd_);
}

bool Joystick::open(const std::string& dev) {
  fd_ = ::open(dev.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  return fd_ >= 0;
}

unsigned Joystick::poll_events() {
  unsigned pressed = 0;
  js_event e;
  while (fd_ >= 0 && ::read(fd_, &e, sizeof e) == sizeof e) {
    const unsigned type = e.type & ~JS_EVENT_INIT;
    if (type == JS_EVENT_AXIS && e.number < 8) axis_[e.number] = e.value / 32767.0;
    if (type == JS_EVENT_BUTTON && e.number < 8) {
      // The initial state events (JS_EVENT_INIT) are not presses.
      if (e.value && !button_[e.number] && !(e.type & JS_EVENT_INIT)) pressed |= 1u << e.number;
      button_[e.number] = e.value != 0;
    }
  }
  return pressed;
}

}  // namespace auger::op

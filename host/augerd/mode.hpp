// augerd's mode (docs/daemon.md "The loop"), its name in `status` and its code in the log's
// `mode` column (docs/daemon.md "The log"; auger replay reads the codes).
#pragma once

namespace augerd {

enum class Mode { stopped = 0, idle = 1, vel = 2, go_to = 3, follow = 4, hold = 5, spin = 6 };

inline const char* mode_name(Mode m) {
  switch (m) {
    case Mode::stopped: return "stopped";
    case Mode::idle: return "idle";
    case Mode::vel: return "vel";
    case Mode::go_to: return "goto";
    case Mode::follow: return "follow";
    case Mode::hold: return "hold";
    case Mode::spin: return "spin";
  }
  return "?";
}

// The log's `mode` column.
inline int mode_code(Mode m) { return static_cast<int>(m); }

// The controller tracks poses in these (allocator and spin are refused then).
inline bool tracking(Mode m) { return m == Mode::go_to || m == Mode::follow || m == Mode::hold; }

}  // namespace augerd

// Four simulated motor modules (the real firmware under simavr, sim/simmod.h) paced to real
// time on a thread, each behind a pty the test creates itself (sim/pty_bridge.h), so that the
// test can cut, corrupt, close and reopen one module's line while augerd runs on the others,
// and can read every telemetry frame the modules send (the motors' state after augerd is gone).
#pragma once

#include <array>
#include <atomic>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "protocol.h"

struct simmod_t;

class SimRig {
 public:
  struct ModuleView {
    proto_telemetry_t tm{};
    double tm_wall_s = 0;          // wall time (CLOCK_MONOTONIC) of the latest telemetry frame
    long tm_count = 0;
    double last_setpoint_wall_s = 0;  // when the module last received a valid setpoint (its
                                      // simulated time, mapped to wall time like pwm_off_wall_s)
    long setpoints = 0;
    // Wall time at which the motor's PWM pin last went quiet (low for more than 4 ms: the
    // motor is off since then), taken from the simulated pin itself; 0 while it is driven.
    double pwm_off_wall_s = 0;
  };

  // ids[m]: the id module m is given (EEPROM) before any host connects, and its telemetry
  // period. Port k of the rig (dir/portK) is wired to module perm[k].
  SimRig(const std::string& dir, std::array<int, 4> ids, std::array<int, 4> perm,
         std::array<int, 4> telemetry_ms = {10, 10, 10, 10});
  ~SimRig();

  std::string port(int k) const { return dir_ + "/port" + std::to_string(k); }
  ModuleView module(int m) const;

  // Line faults of rig port k (they act on the bytes from the module to the host).
  void set_mute(int k, bool mute) { mute_[std::size_t(k)] = mute; }
  void set_corrupt(int k, bool corrupt) { corrupt_[std::size_t(k)] = corrupt; }
  // Closes the pty (the host sees a hang-up); reopen_port(k) makes a new one at the same path.
  void close_port(int k) { close_req_[std::size_t(k)] = true; }
  void reopen_port(int k) { reopen_req_[std::size_t(k)] = true; }

  // Forces module m's battery voltage (0: back to the pack model), e.g. an under-voltage fault.
  void set_battery_v(int m, double v) { battery_req_[std::size_t(m)] = v; }
  // Runs f on the simulation between two of its steps (e.g. simmod_lock_shaft, simmod_reset_as).
  void in_sim(std::function<void(simmod_t*)> f);

  static double wall_s();

 private:
  void loop();
  static void on_byte(void* ctx, int module, uint8_t byte, double t_s);

  std::string dir_;
  std::array<int, 4> perm_;
  simmod_t* sim_ = nullptr;
  struct Bridge;
  std::array<Bridge*, 4> bridges_{};
  std::array<proto_parser_t, 4> from_module_{}, to_module_{};
  std::array<ModuleView, 4> views_{};
  mutable std::mutex mutex_;
  std::array<std::atomic<bool>, 4> mute_{}, corrupt_{}, close_req_{}, reopen_req_{};
  std::array<std::atomic<double>, 4> battery_req_{};  // negative: no request
  std::vector<std::function<void(simmod_t*)>> actions_;  // guarded by mutex_
  std::atomic<bool> stop_{false};
  double t0_wall_s_ = 0;
  std::thread thread_;
};

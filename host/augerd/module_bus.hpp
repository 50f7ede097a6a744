// The four motor modules on their serial ports, as augerd's loop sees them: identification at
// start-up (mapped by id, whatever the port order; protocol version and settings checked), the
// non-blocking frame pump (telemetry, identities, settings reports, fault snapshots), the link's
// safety checks (docs/daemon.md "Safety"), setpoints out, and the modules' part of `status all`.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "module_adapter.hpp"
#include "module_link.hpp"
#include "status.hpp"

namespace augerd {

struct Module {
  std::string port;
  std::unique_ptr<auger::io::ModuleLink> link;  // null while the port is closed after a failure
  proto_identity_t identity{};
  bool identified = false;   // after a reopen: telemetry counts only once the identity matched
  auger::io::ModuleTelemetry tm;  // latest telemetry (keyed on the module's time_ms), fresh this cycle
  double last_valid_s = 0;   // loop time of the last valid telemetry
  uint64_t bytes_at_valid = 0;    // bytes received up to the last valid telemetry
  bool lost = false;         // no valid telemetry for telemetry_timeout_s, or the port failed
  double reopen_at_s = 0;    // next reopen attempt after a port failure
  double request_at_s = 0;   // next identity request after a reopen
  uint16_t seq = 0;          // next setpoint sequence number
  uint8_t telemetry_period_ms = 10;  // the module's setting (CONFIG_REPORT): augerd follows it
  bool clearing = false;     // CLEAR_FAULTS is sent until the module acknowledges clear_seq
  uint16_t clear_seq = 0;
  double cmd_rpm = 0;        // the setpoint sent last (status all)
  bool answering() const { return link && !lost; }
};

class ModuleBus {
 public:
  // A fault of one module: reason_token for `status` (no-telemetry, F_OVERCURRENT, ...), detail
  // in words. augerd stops every screw on it.
  using FaultSink = std::function<void(int module, const std::string& reason_token, const std::string& detail)>;

  // Something worth the event log that is not a fault (a lost module answers again, a module's
  // FAULT snapshot, a changed telemetry period).
  using EventSink = std::function<void(int module, const std::string& what, const std::string& action)>;

  ModuleBus(const std::array<std::string, 4>& ports, unsigned baud, double identity_timeout_s,
            double telemetry_timeout_s, FaultSink on_fault, EventSink on_event);

  // Opens the ports, identifies the modules (refusing another protocol version), reads each
  // one's settings (its telemetry period) and maps them by id. Throws std::runtime_error.
  void open();
  // The loop's clock starts: times so far (CLOCK_MONOTONIC) become loop times.
  void start_clock(double t0_mono_s);
  // One cycle: every pending frame from every port (non-blocking), then the safety checks.
  // Latched fault bits count only while enabled.
  void pump(double t_s, bool enabled);
  // One setpoint per module (sequence numbers, ENABLE, CLEAR_FAULTS after clear_faults()).
  // Saturates to the wire's range; a non-finite speed is sent as 0 and reported as a fault.
  void send(double t_s, const std::array<double, 4>& rpm, bool enable);
  // `enable`: CLEAR_FAULTS until each module acknowledges it.
  void clear_faults();
  // -1 if every module answers, else the first one that does not.
  int first_not_answering() const;

  const Module& module(int i) const { return modules_[static_cast<std::size_t>(i)]; }
  // No valid telemetry this long: the module is lost. The configured timeout, or two of the
  // module's telemetry periods and a control period, whichever is longer.
  double telemetry_timeout_s(const Module& m) const;
  // The per-module fields of `status all` (docs/daemon-protocol.md).
  void status_fields(double t_s, std::array<auger::daemon::ModuleStatus, 4>& out) const;

 private:
  void pump_one(Module& m, int index, double t_s);
  void check(Module& m, int index, double t_s, bool enabled);
  void port_failed(Module& m, int index, double t_s, const std::string& why);
  std::array<std::string, 4> ports_;
  unsigned baud_;
  double identity_timeout_s_, telemetry_timeout_s_;
  FaultSink fault_;
  EventSink event_;
  std::array<Module, 4> modules_;  // index = module id = screw index
};

}  // namespace augerd

// The modules as augerd's loop sees them (module_bus.hpp).
#include "module_bus.hpp"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <optional>
#include <stdexcept>
#include <vector>

#include <unistd.h>

#include "clock.hpp"
#include "module_adapter.hpp"
#include "status_text.hpp"

namespace augerd {
namespace {

// 16-bit sequence numbers wrap: a is at or after b when the signed difference is >= 0.
bool seq_at_or_after(uint16_t a, uint16_t b) { return int16_t(uint16_t(a - b)) >= 0; }

using auger::io::fault_bits_text;  // every call has a fault bit set

using Links = std::array<std::unique_ptr<auger::io::ModuleLink>, 4>;

// Pumps the four links until each has sent a frame `decode` accepts (into T), or throws after
// timeout_s naming the ports and `what`; `between(waited_s, got)` runs between rounds. Start-up
// only, before the loop.
template <typename T, typename Decode, typename Between>
std::array<T, 4> collect_frames(Links& links, const std::array<std::string, 4>& ports, double timeout_s,
                                const std::string& what, Decode decode, Between between) {
  std::array<std::optional<T>, 4> got;
  const double start = clock_s(CLOCK_MONOTONIC);
  std::vector<proto_frame_t> frames;
  for (;;) {
    bool all = true;
    for (std::size_t i = 0; i < 4; ++i) {
      frames.clear();
      links[i]->pump(frames);
      for (const auto& f : frames) {
        T v;
        if (!got[i] && decode(&f, &v)) got[i] = v;
      }
      all = all && got[i];
    }
    if (all) break;
    const double waited = clock_s(CLOCK_MONOTONIC) - start;
    between(waited, got);
    if (waited > timeout_s) {
      std::string missing;
      for (std::size_t i = 0; i < 4; ++i)
        if (!got[i]) missing += " " + ports[i];
      throw std::runtime_error("no " + what + " within " + std::to_string(timeout_s) + " s from the module(s) on" +
                               missing + " (powered? right port and baud?)");
    }
    usleep(2000);
  }
  std::array<T, 4> out;
  for (std::size_t i = 0; i < 4; ++i) out[i] = *got[i];
  return out;
}

// REQUEST frame; timeout_s 0 in the loop: never wait for room in the port.
void request(auger::io::ModuleLink& link, uint8_t what, double timeout_s = 1.0) {
  uint8_t buf[PROTO_MAX_FRAME];
  proto_request_t rq{what};
  link.send_frame(buf, proto_encode_request(&rq, buf), timeout_s);
}

}  // namespace

ModuleBus::ModuleBus(const std::array<std::string, 4>& ports, unsigned baud, double identity_timeout_s,
                     double telemetry_timeout_s, FaultSink on_fault, EventSink on_event)
    : ports_(ports),
      baud_(baud),
      identity_timeout_s_(identity_timeout_s),
      telemetry_timeout_s_(telemetry_timeout_s),
      fault_(std::move(on_fault)),
      event_(std::move(on_event)) {}

void ModuleBus::open() {
  Links links;
  // Open every port first: each open resets its module (DTR), so they boot in parallel.
  for (std::size_t i = 0; i < 4; ++i) links[i] = std::make_unique<auger::io::ModuleLink>(ports_[i], baud_);
  bool asked = false;
  const auto ids = collect_frames<proto_identity_t>(
      links, ports_, identity_timeout_s_, "identity frame", proto_decode_identity,
      [&](double waited, const std::array<std::optional<proto_identity_t>, 4>& got) {
        // A module that was not reset by the open (no DTR) never sends one by itself: ask
        // late, after the bootloader's time, so the request does not go to the bootloader.
        if (asked || waited <= 0.75 * identity_timeout_s_) return;
        for (std::size_t i = 0; i < 4; ++i)
          if (!got[i]) request(*links[i], PROTO_T_IDENTITY);
        asked = true;
      });
  std::array<int, 4> port_of_id{-1, -1, -1, -1};
  for (std::size_t i = 0; i < 4; ++i) {
    const proto_identity_t& id = ids[i];
    auger::io::require_protocol(id, ports_[i], "augerd");
    if (id.module_id > 3)
      throw std::runtime_error(ports_[i] + ": module id " + std::to_string(id.module_id) +
                               " is not a screw index 0..3 (set it with auger-module PORT set id=N)");
    if (port_of_id[id.module_id] >= 0)
      throw std::runtime_error("duplicate module id " + std::to_string(id.module_id) + " on " +
                               ports_[std::size_t(port_of_id[id.module_id])] + " and " + ports_[i]);
    port_of_id[id.module_id] = int(i);
  }
  // Each module's telemetry period (its settings): the no-telemetry timeout follows it.
  for (auto& link : links) request(*link, PROTO_T_CONFIG_REPORT);
  const auto cfgs = collect_frames<proto_config_t>(links, ports_, identity_timeout_s_, "settings report",
                                                   proto_decode_config_report, [](double, const auto&) {});
  // Four ports with four distinct ids in 0..3: every id is present.
  const double now = clock_s(CLOCK_MONOTONIC);
  for (std::size_t k = 0; k < 4; ++k) {
    const std::size_t i = std::size_t(port_of_id[k]);
    Module& m = modules_[k];
    m.port = ports_[i];
    m.link = std::move(links[i]);
    m.identity = ids[i];
    m.identified = true;
    m.telemetry_period_ms = cfgs[i].telemetry_period_ms;
    m.last_valid_s = now;  // converted to loop time by start_clock()
    std::fprintf(stderr,
                 "augerd: module %zu on %s (firmware %u.%u.%u, protocol %u, telemetry every %u ms, settings from %s, "
                 "last reset: %s)\n",
                 k, m.port.c_str(), m.identity.fw_major, m.identity.fw_minor, m.identity.fw_patch,
                 m.identity.protocol_version, m.telemetry_period_ms,
                 auger::io::settings_origin_text(m.identity.flags).c_str(),
                 auger::io::reset_cause_text(m.identity.reset_cause).c_str());
  }
}

double ModuleBus::telemetry_timeout_s(const Module& m) const {
  return std::max(telemetry_timeout_s_, (2.0 * m.telemetry_period_ms + 10.0) / 1000.0);
}

void ModuleBus::start_clock(double t0_mono_s) {
  for (auto& m : modules_) m.last_valid_s -= t0_mono_s;
}

void ModuleBus::pump(double t_s, bool enabled) {
  for (int i = 0; i < 4; ++i) modules_[std::size_t(i)].tm.fresh = false;
  for (int i = 0; i < 4; ++i) pump_one(modules_[std::size_t(i)], i, t_s);
  for (int i = 0; i < 4; ++i) check(modules_[std::size_t(i)], i, t_s, enabled);
}

void ModuleBus::port_failed(Module& m, int index, double t_s, const std::string& why) {
  m.link.reset();
  m.lost = true;
  m.reopen_at_s = t_s + 1.0;
  fault_(index, "port-error", why);
}

void ModuleBus::pump_one(Module& m, int index, double t_s) {
  if (!m.link) {
    if (t_s < m.reopen_at_s) return;
    m.reopen_at_s = t_s + 1.0;
    try {
      m.link = std::make_unique<auger::io::ModuleLink>(m.port, baud_);
      m.identified = false;
      m.request_at_s = t_s + 0.75 * identity_timeout_s_;
      std::fprintf(stderr, "augerd: t=%.3f s: reopened %s, waiting for module %d's identity\n", t_s, m.port.c_str(),
                   index);
    } catch (const std::exception&) {
      return;  // still gone; no message every second
    }
  }
  static thread_local std::vector<proto_frame_t> frames;
  frames.clear();
  try {
    m.link->pump(frames);
  } catch (const std::exception& e) {
    port_failed(m, index, t_s, e.what());
    return;
  }
  for (const auto& f : frames) {
    proto_identity_t id;
    proto_telemetry_t tm;
    proto_config_t cfg;
    proto_fault_t ft;
    if (proto_decode_fault(&f, &ft)) {
      // The module's own record of a trip: what it measured at that moment (the telemetry
      // that reports the fault bit follows, and check() stops the robot on it).
      const std::string text = auger::io::fault_snapshot_text(ft);
      std::fprintf(stderr, "augerd: t=%.3f s: module %d (%s): %s\n", t_s, index, m.port.c_str(), text.c_str());
      event_(index, "fault-snapshot", text);
    } else if (proto_decode_config_report(&f, &cfg)) {
      if (cfg.telemetry_period_ms != m.telemetry_period_ms)
        event_(index, "telemetry-period",
               "the module sends telemetry every " + std::to_string(cfg.telemetry_period_ms) + " ms; augerd follows it");
      m.telemetry_period_ms = cfg.telemetry_period_ms;
    } else if (proto_decode_identity(&f, &id)) {
      if (id.module_id != index) {
        m.link.reset();
        m.lost = true;
        m.reopen_at_s = t_s + 1.0;
        fault_(index, "wrong-id", "the module now on this port has id " + std::to_string(id.module_id));
        return;
      }
      if (m.identified) {
        // An identity frame nobody asked for: the module has rebooted (power, watchdog).
        fault_(index, "reset", "the module reset; last reset: " + auger::io::reset_cause_text(id.reset_cause) +
                                   ", settings from " + auger::io::settings_origin_text(id.flags));
      }
      m.identified = true;
      m.identity = id;
      m.tm.received = false;  // its clock restarted: the next telemetry is not "older"
      // Its settings may be others now (defaults after a corrupt EEPROM): the telemetry period.
      try {
        request(*m.link, PROTO_T_CONFIG_REPORT, 0.0);
      } catch (const std::exception&) {
      }
    } else if (proto_decode_telemetry(&f, &tm) && m.identified) {
      // Key on the module's clock: a frame not newer than the last one is stale or repeated.
      if (m.tm.received) {
        const int32_t step_ms = int32_t(tm.time_ms - m.tm.frame.time_ms);
        if (step_ms <= 0 && step_ms > -1000) continue;
        // Far back: the module restarted and its identity frame was lost.
        if (step_ms <= -1000) fault_(index, "reset", "the module's clock went back " + std::to_string(-step_ms) + " ms");
      }
      m.tm.take(tm);
      m.last_valid_s = t_s;
      m.bytes_at_valid = m.link->bytes_received();
    }
  }
  if (m.link && !m.identified && t_s >= m.request_at_s) {
    try {
      request(*m.link, PROTO_T_IDENTITY, 0.0);
    } catch (const std::exception&) {
    }
    m.request_at_s = t_s + 0.5;
  }
}

void ModuleBus::check(Module& m, int i, double t_s, bool enabled) {
  if (m.tm.fresh && m.lost) {
    m.lost = false;
    std::fprintf(stderr, "augerd: t=%.3f s: module %d answers again; stays stopped until `enable`\n", t_s, i);
    event_(i, "answers-again", "stays stopped until enable");
  }
  if (!m.lost && m.link && t_s - m.last_valid_s > telemetry_timeout_s(m)) {
    m.lost = true;
    const int ms = int(std::lround(1000 * (t_s - m.last_valid_s)));
    const uint64_t garbage = m.link->bytes_received() - m.bytes_at_valid;
    // A frame cut short when the line died is not corruption: ask for two frames' worth.
    if (garbage >= 2 * PROTO_FRAME_SIZE(PROTO_LEN_TELEMETRY))
      fault_(i, "corrupt-frames", "only corrupt frames for " + std::to_string(ms) + " ms (" + std::to_string(garbage) +
                                      " bytes without a valid frame)");
    else
      fault_(i, "no-telemetry", "no telemetry for " + std::to_string(ms) + " ms");
  }
  if (m.tm.fresh && m.clearing && seq_at_or_after(m.tm.frame.seq_ack, m.clear_seq)) m.clearing = false;
  // Latched faults count once the module has seen our CLEAR_FAULTS (they may persist).
  const uint16_t status = m.tm.frame.status;
  if (m.tm.fresh && enabled && !m.clearing && (status & PROTO_F_MASK))
    fault_(i, fault_bits_text(status), "reports " + fault_bits_text(status));
}

void ModuleBus::send(double t_s, const std::array<double, 4>& rpm, bool enable) {
  for (int i = 0; i < 4; ++i) {
    Module& m = modules_[std::size_t(i)];
    m.cmd_rpm = rpm[std::size_t(i)];
    if (!m.link) continue;
    uint8_t buf[PROTO_MAX_FRAME];
    bool finite = true;
    const std::size_t n = auger::io::encode_setpoint(m.seq++, rpm[std::size_t(i)], enable, m.clearing, buf, &finite);
    try {
      // No waiting: a port that cannot take 11 bytes is not draining (module gone).
      m.link->send_frame(buf, n, 0.0);
    } catch (const std::exception& e) {
      port_failed(m, i, t_s, e.what());
      continue;
    }
    if (!finite) fault_(i, "bad-setpoint", "a non-finite setpoint was computed for it (sent 0 without ENABLE)");
  }
}

void ModuleBus::clear_faults() {
  for (auto& m : modules_) {
    m.clearing = true;
    m.clear_seq = m.seq;
  }
}

int ModuleBus::first_not_answering() const {
  for (int i = 0; i < 4; ++i)
    if (!modules_[std::size_t(i)].answering()) return i;
  return -1;
}

void ModuleBus::status_fields(double t_s, std::array<auger::daemon::ModuleStatus, 4>& out) const {
  for (int i = 0; i < 4; ++i) {
    const Module& m = modules_[std::size_t(i)];
    const proto_telemetry_t& tm = m.tm.frame;
    auger::daemon::ModuleStatus& s = out[std::size_t(i)];
    s.port = m.port;
    s.lost = m.lost || !m.link;
    s.tm_age_s = m.tm.received && !m.lost ? t_s - m.last_valid_s : -1.0;
    s.time_ms = tm.time_ms;
    s.omega_rpm = m.tm.omega_rpm();
    s.cmd_rpm = m.cmd_rpm;
    s.omega_cmd_rpm = m.tm.omega_cmd_rpm();
    s.position_counts = tm.position_counts;
    s.current_a = m.tm.current_a();
    s.voltage_v = m.tm.voltage_v();
    s.pwm = m.tm.pwm();
    s.status = tm.status;
    s.faults = (tm.status & PROTO_F_MASK) ? fault_bits_text(tm.status) : "none";
    s.rx_errors = tm.rx_errors;
    s.encoder_errors = tm.encoder_errors;
    s.host_crc_errors = m.link ? m.link->parser_stats().crc_errors : 0;
    s.host_header_errors = m.link ? m.link->parser_stats().header_errors : 0;
    s.host_bytes_skipped = m.link ? m.link->parser_stats().bytes_discarded : 0;
  }
}

}  // namespace augerd

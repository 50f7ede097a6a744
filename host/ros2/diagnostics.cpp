// augerd's /diagnostics entries and online estimate data (diagnostics.hpp), without DDS.
#include "diagnostics.hpp"

#include <cstdio>

#include "auger/online_estimator.hpp"
#include "protocol.h"
#include "status_text.hpp"

namespace auger::ros2 {
namespace {

std::string num(const char* fmt, double v) {
  char b[64];
  std::snprintf(b, sizeof b, fmt, v);
  return b;
}

// The online estimator's entry: WARN while the fallback is latched (the robot drives on with the
// configured terrain: a warning, never an error, docs/daemon.md "Online identification").
DiagnosticEntry online_entry(const OnlineSnapshot& o) {
  DiagnosticEntry x;
  x.name = "augerd: online estimator";
  x.hardware_id = "augerd";
  const bool fallback = o.fallback[0] != '\0';
  x.level = fallback ? 1 : 0;
  x.message = fallback ? std::string("fallback to the configured terrain (") + o.fallback.data() + ")"
                       : std::string("ground believed: ") + o.believed.data();
  x.kv = {{"believed_terrain", o.believed.data()}, {"believed_by", o.basis.data()}};
  for (int k = 0; k < kOnlineParams; ++k) {
    const std::string name = auger::online_param_name(k), unit = std::string(" ") + auger::online_param_unit(k);
    x.kv.emplace_back(name, num("%.4g", o.value[k]) + unit + (o.held[k] ? " (held)" : ""));
    x.kv.emplace_back(name + "_sd", num("%.2g", o.sd[k]) + unit);
  }
  for (int k = 0; k < o.effects && k < OnlineSnapshot::kMaxEffects; ++k) {
    const std::string name = o.effect_name[k].data(), unit = std::string(" ") + o.effect_unit[k].data();
    x.kv.emplace_back(name, num("%.4g", o.effect_value[k]) + unit);
    x.kv.emplace_back(name + "_sd", num("%.2g", o.effect_sd[k]) + unit);
  }
  x.kv.emplace_back("cusum", num("%.3g", o.cusum));
  x.kv.emplace_back("cusum_threshold", num("%.3g", o.cusum_threshold));
  x.kv.emplace_back("changes", std::to_string(o.changes));
  x.kv.emplace_back("fallback", fallback ? o.fallback.data() : "none");
  return x;
}

}  // namespace

std::vector<DiagnosticEntry> diagnostics(const Snapshot& s, long cycles_skipped) {
  static const char* kWhere[4] = {"front-right", "rear-right", "rear-left", "front-left"};
  std::vector<DiagnosticEntry> st;
  // (num has its own buffer: the status word below in b once came out as the pwm formatted
  // after it, when num wrote into b too.)
  char b[128];
  for (int i = 0; i < 4; ++i) {
    const ModuleSnapshot& m = s.module[i];
    DiagnosticEntry x;
    x.name = "augerd: module " + std::to_string(i) + " (" + kWhere[i] + ")";
    std::snprintf(b, sizeof b, "%s firmware %u.%u.%u", m.port.data(), m.fw[0], m.fw[1], m.fw[2]);
    x.hardware_id = b;
    const bool faults = (m.status & PROTO_F_MASK) != 0;
    if (!m.answering) {
      x.level = 3;  // STALE
      x.message = "not answering";
    } else if (faults) {
      x.level = 2;  // ERROR
      x.message = "fault: " + auger::io::fault_bits_text(m.status);
    } else if (s.fault_module == i) {
      x.level = 1;  // WARN: the module is fine now, the robot waits for `enable`
      x.message = std::string("stopped the robot (") + s.fault_reason.data() + "); waiting for enable";
    } else {
      x.message = "ok";
    }
    std::snprintf(b, sizeof b, "0x%04x", m.status);
    x.kv = {{"omega_rpm", num("%.2f", m.omega_rpm)},
            {"cmd_rpm", num("%.2f", m.cmd_rpm)},
            {"current_a", num("%.3f", m.current_a)},
            {"voltage_v", num("%.3f", m.voltage_v)},
            {"pwm", num("%.4f", m.pwm)},
            {"status", b},
            {"faults", faults ? auger::io::fault_bits_text(m.status) : "none"},
            {"rx_errors", std::to_string(m.rx_errors)},
            {"encoder_errors", std::to_string(m.encoder_errors)},
            {"host_crc_errors", std::to_string(m.crc_errors)},
            {"host_header_errors", std::to_string(m.header_errors)},
            {"host_bytes_skipped", std::to_string(m.bytes_skipped)}};
    st.push_back(std::move(x));
  }
  {
    DiagnosticEntry x;
    x.name = "augerd: controller";
    x.hardware_id = "augerd";
    x.level = s.fault_module >= 0 ? 1 : 0;
    x.message = s.fault_module >= 0
                    ? "stopped by module " + std::to_string(s.fault_module) + " (" + s.fault_reason.data() + ")"
                    : std::string("mode ") + s.mode.data();
    x.kv = {{"mode", s.mode.data()},
            {"enabled", s.enabled ? "1" : "0"},
            {"loop_dt_s", num("%.5f", s.loop_dt_s)},
            {"loop_jitter_max_s", num("%.5f", s.loop_jitter_max_s)},
            {"ros2_hook_max_us", num("%.1f", s.hook_max_us)},
            {"ros2_inputs_applied", std::to_string(s.inputs_applied)},
            {"ros2_inputs_refused", std::to_string(s.inputs_refused)},
            {"ros2_last_refusal", s.last_refusal[0] ? s.last_refusal.data() : "none"},
            {"ros2_cycles_skipped", std::to_string(cycles_skipped)}};
    st.push_back(std::move(x));
  }
  if (s.online.enabled) st.push_back(online_entry(s.online));
  return st;
}

void online_estimate_data(const OnlineSnapshot& o, double data[kOnlineParams * kOnlineColumns]) {
  for (int k = 0; k < kOnlineParams; ++k) {
    data[kOnlineColumns * k] = o.value[k];
    data[kOnlineColumns * k + 1] = o.sd[k];
  }
}

}  // namespace auger::ros2

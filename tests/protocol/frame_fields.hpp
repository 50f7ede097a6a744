// Field-by-field views of the protocol structs for comparisons in tests (floats by their
// bits, so NaN payloads and -0.0 count as values).
#pragma once

#include "protocol.h"

#include <cstdint>
#include <cstring>
#include <tuple>

namespace auger::test {

inline uint32_t bits(float f)
{
    uint32_t b;
    std::memcpy(&b, &f, sizeof b);
    return b;
}

inline auto fields(const proto_setpoint_t& s) { return std::make_tuple(s.seq, s.omega_crpm, s.flags); }
inline auto fields(const proto_request_t& r) { return std::make_tuple(r.what); }
inline auto fields(const proto_config_t& c)
{
    return std::make_tuple(c.module_id, c.dir_sign, c.flags, c.counts_per_rev_x100, bits(c.kp),
                           bits(c.ki), bits(c.kd), c.omega_max_crpm, c.overcurrent_ma,
                           c.overcurrent_samples, c.undervoltage_mv, c.undervoltage_hyst_mv,
                           c.motor_rated_mv, c.cmd_timeout_ms, c.foldback_ma, c.stall_current_ma,
                           c.stall_time_ms, c.telemetry_period_ms);
}
inline auto fields(const proto_telemetry_t& t)
{
    return std::make_tuple(t.time_ms, t.seq_ack, t.omega_crpm, t.omega_cmd_crpm, t.position_counts,
                           t.current_ma, t.voltage_mv, t.duty_x10000, t.status, t.rx_errors,
                           t.encoder_errors);
}
inline auto fields(const proto_identity_t& i)
{
    return std::make_tuple(i.module_id, i.protocol_version, i.fw_major, i.fw_minor, i.fw_patch,
                           i.reset_cause, i.flags);
}

inline auto fields(const proto_fault_t& f)
{
    return std::make_tuple(f.time_ms, f.faults, f.status, f.current_ma, f.voltage_mv, f.omega_crpm,
                           f.omega_cmd_crpm, f.duty_x10000);
}

}  // namespace auger::test

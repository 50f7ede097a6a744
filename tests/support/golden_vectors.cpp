#include "golden_vectors.hpp"

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace auger::test {
namespace {

[[noreturn]] void fail(const std::string& where, const std::string& what)
{
    throw std::runtime_error(where + ": " + what);
}

std::string where_of(const GoldenVector& v)
{
    return golden_vectors_path() + ":" + std::to_string(v.line) + " (" + v.name + ")";
}

const std::string& field(const GoldenVector& v, const std::string& key)
{
    auto it = v.fields.find(key);
    if (it == v.fields.end()) fail(where_of(v), "missing field '" + key + "'");
    return it->second;
}

template <typename T>
T int_field(const GoldenVector& v, const std::string& key)
{
    const std::string& s = field(v, key);
    errno = 0;
    char* end = nullptr;
    long long x = std::strtoll(s.c_str(), &end, 10);
    if (errno != 0 || end == s.c_str() || *end != '\0' ||
        x < static_cast<long long>(std::numeric_limits<T>::min()) ||
        x > static_cast<long long>(std::numeric_limits<T>::max())) {
        fail(where_of(v), "field '" + key + "' = '" + s + "' is not a valid integer of its type");
    }
    return static_cast<T>(x);
}

float float_field(const GoldenVector& v, const std::string& key)
{
    const std::string& s = field(v, key);
    char* end = nullptr;
    float x = std::strtof(s.c_str(), &end);  // hexadecimal floats are read exactly
    if (end == s.c_str() || *end != '\0') fail(where_of(v), "field '" + key + "' = '" + s + "' is not a float");
    return x;
}

}  // namespace

std::string golden_vectors_path() { return AUGER_GOLDEN_VECTORS; }

std::vector<GoldenVector> load_golden_vectors(const std::string& path)
{
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open");
    std::vector<GoldenVector> out;
    std::string text;
    int line_no = 0;
    while (std::getline(in, text)) {
        ++line_no;
        if (text.empty() || text[0] == '#') continue;
        const std::string where = path + ":" + std::to_string(line_no);
        auto bar = text.find(" | ");
        if (bar == std::string::npos) fail(where, "no ' | ' between fields and bytes");
        GoldenVector v;
        v.line = line_no;
        std::istringstream left(text.substr(0, bar));
        if (!(left >> v.name >> v.kind)) fail(where, "expected NAME TYPE");
        std::string kv;
        while (left >> kv) {
            auto eq = kv.find('=');
            if (eq == std::string::npos) fail(where, "field '" + kv + "' has no '='");
            v.fields[kv.substr(0, eq)] = kv.substr(eq + 1);
        }
        std::istringstream right(text.substr(bar + 3));
        std::string hex;
        while (right >> hex) {
            char* end = nullptr;
            unsigned long b = std::strtoul(hex.c_str(), &end, 16);
            if (hex.size() != 2 || *end != '\0' || b > 0xFF) fail(where, "bad byte '" + hex + "'");
            v.bytes.push_back(static_cast<uint8_t>(b));
        }
        out.push_back(std::move(v));
    }
    return out;
}

proto_setpoint_t to_setpoint(const GoldenVector& v)
{
    proto_setpoint_t s{};
    s.seq = int_field<uint16_t>(v, "seq");
    s.omega_crpm = int_field<int16_t>(v, "omega_crpm");
    s.flags = int_field<uint8_t>(v, "flags");
    return s;
}

proto_config_t to_config(const GoldenVector& v)
{
    proto_config_t c{};
    c.module_id = int_field<uint8_t>(v, "module_id");
    c.dir_sign = int_field<int8_t>(v, "dir_sign");
    c.flags = int_field<uint8_t>(v, "flags");
    c.counts_per_rev_x100 = int_field<uint32_t>(v, "counts_per_rev_x100");
    c.kp = float_field(v, "kp");
    c.ki = float_field(v, "ki");
    c.kd = float_field(v, "kd");
    c.omega_max_crpm = int_field<uint16_t>(v, "omega_max_crpm");
    c.overcurrent_ma = int_field<uint16_t>(v, "overcurrent_ma");
    c.overcurrent_samples = int_field<uint8_t>(v, "overcurrent_samples");
    c.undervoltage_mv = int_field<uint16_t>(v, "undervoltage_mv");
    c.undervoltage_hyst_mv = int_field<uint16_t>(v, "undervoltage_hyst_mv");
    c.motor_rated_mv = int_field<uint16_t>(v, "motor_rated_mv");
    c.cmd_timeout_ms = int_field<uint16_t>(v, "cmd_timeout_ms");
    c.foldback_ma = int_field<uint16_t>(v, "foldback_ma");
    c.stall_current_ma = int_field<uint16_t>(v, "stall_current_ma");
    c.stall_time_ms = int_field<uint16_t>(v, "stall_time_ms");
    c.telemetry_period_ms = int_field<uint8_t>(v, "telemetry_period_ms");
    return c;
}

proto_request_t to_request(const GoldenVector& v)
{
    proto_request_t r{};
    r.what = int_field<uint8_t>(v, "what");
    return r;
}

proto_telemetry_t to_telemetry(const GoldenVector& v)
{
    proto_telemetry_t t{};
    t.time_ms = int_field<uint32_t>(v, "time_ms");
    t.seq_ack = int_field<uint16_t>(v, "seq_ack");
    t.omega_crpm = int_field<int16_t>(v, "omega_crpm");
    t.omega_cmd_crpm = int_field<int16_t>(v, "omega_cmd_crpm");
    t.position_counts = int_field<int32_t>(v, "position_counts");
    t.current_ma = int_field<int16_t>(v, "current_ma");
    t.voltage_mv = int_field<uint16_t>(v, "voltage_mv");
    t.duty_x10000 = int_field<int16_t>(v, "duty_x10000");
    t.status = int_field<uint16_t>(v, "status");
    t.rx_errors = int_field<uint16_t>(v, "rx_errors");
    t.encoder_errors = int_field<uint16_t>(v, "encoder_errors");
    return t;
}

proto_identity_t to_identity(const GoldenVector& v)
{
    proto_identity_t i{};
    i.module_id = int_field<uint8_t>(v, "module_id");
    i.protocol_version = int_field<uint8_t>(v, "protocol_version");
    i.fw_major = int_field<uint8_t>(v, "fw_major");
    i.fw_minor = int_field<uint8_t>(v, "fw_minor");
    i.fw_patch = int_field<uint8_t>(v, "fw_patch");
    i.reset_cause = int_field<uint8_t>(v, "reset_cause");
    i.flags = int_field<uint8_t>(v, "flags");
    return i;
}

proto_fault_t to_fault(const GoldenVector& v)
{
    proto_fault_t f{};
    f.time_ms = int_field<uint32_t>(v, "time_ms");
    f.faults = int_field<uint16_t>(v, "faults");
    f.status = int_field<uint16_t>(v, "status");
    f.current_ma = int_field<int16_t>(v, "current_ma");
    f.voltage_mv = int_field<uint16_t>(v, "voltage_mv");
    f.omega_crpm = int_field<int16_t>(v, "omega_crpm");
    f.omega_cmd_crpm = int_field<int16_t>(v, "omega_cmd_crpm");
    f.duty_x10000 = int_field<int16_t>(v, "duty_x10000");
    return f;
}

std::vector<uint8_t> encode_fields(const GoldenVector& v)
{
    std::vector<uint8_t> buf(PROTO_MAX_FRAME);
    size_t n = 0;
    if (v.kind == "setpoint") {
        auto s = to_setpoint(v);
        n = proto_encode_setpoint(&s, buf.data());
    } else if (v.kind == "config") {
        auto c = to_config(v);
        n = proto_encode_config(&c, buf.data());
    } else if (v.kind == "config_report") {
        auto c = to_config(v);
        n = proto_encode_config_report(&c, buf.data());
    } else if (v.kind == "request") {
        auto r = to_request(v);
        n = proto_encode_request(&r, buf.data());
    } else if (v.kind == "telemetry") {
        auto t = to_telemetry(v);
        n = proto_encode_telemetry(&t, buf.data());
    } else if (v.kind == "identity") {
        auto i = to_identity(v);
        n = proto_encode_identity(&i, buf.data());
    } else if (v.kind == "fault") {
        auto f = to_fault(v);
        n = proto_encode_fault(&f, buf.data());
    } else {
        fail(where_of(v), "unknown frame kind '" + v.kind + "'");
    }
    buf.resize(n);
    return buf;
}

}  // namespace auger::test

// Frame packing: golden vectors from the independent generator, round trips of every type
// with field limits, and the CRC against its published check value.
#include "frame_fields.hpp"
#include "golden_vectors.hpp"
#include "protocol.h"

#include <catch2/catch.hpp>

#include <cstring>
#include <random>
#include <set>
#include <vector>

using namespace auger::test;

namespace {

std::vector<proto_frame_t> parse_all(const std::vector<uint8_t>& bytes)
{
    proto_parser_t p;
    proto_parser_init(&p);
    std::vector<proto_frame_t> out;
    proto_frame_t f;
    for (uint8_t b : bytes) {
        proto_parser_push(&p, b);
        while (proto_parser_pop(&p, &f)) out.push_back(f);
    }
    return out;
}

template <typename T, typename Decode>
T decode_one(const std::vector<uint8_t>& bytes, Decode decode)
{
    auto frames = parse_all(bytes);
    REQUIRE(frames.size() == 1);
    T out{};
    REQUIRE(decode(&frames[0], &out));
    return out;
}

}  // namespace

TEST_CASE("CRC is CRC-16/MCRF4XX, as avr-libc's _crc_ccitt_update", "[protocol]")
{
    const char* check = "123456789";
    CHECK(proto_crc(reinterpret_cast<const uint8_t*>(check), 9) == 0x6F91);
    CHECK(proto_crc(nullptr, 0) == 0xFFFF);
    // One step from the documented formula, worked by hand in docs/protocol.md.
    CHECK(proto_crc_update(0xFFFF, 0x05) == 0x582A);
}

TEST_CASE("golden vectors: C packing equals the independent generator", "[protocol]")
{
    auto vectors = load_golden_vectors(golden_vectors_path());
    REQUIRE(vectors.size() >= 20);
    std::set<std::string> kinds;
    for (const auto& v : vectors) {
        INFO(v.name << " at line " << v.line);
        kinds.insert(v.kind);
        CHECK(encode_fields(v) == v.bytes);

        auto frames = parse_all(v.bytes);
        REQUIRE(frames.size() == 1);
        const proto_frame_t& f = frames[0];
        CHECK(size_t(f.len) + PROTO_OVERHEAD == v.bytes.size());
        if (v.kind == "setpoint") {
            proto_setpoint_t s{};
            REQUIRE(proto_decode_setpoint(&f, &s));
            CHECK(fields(s) == fields(to_setpoint(v)));
        } else if (v.kind == "config") {
            proto_config_t c{};
            REQUIRE(proto_decode_config(&f, &c));
            CHECK(fields(c) == fields(to_config(v)));
        } else if (v.kind == "config_report") {
            proto_config_t c{};
            REQUIRE(proto_decode_config_report(&f, &c));
            CHECK(fields(c) == fields(to_config(v)));
        } else if (v.kind == "request") {
            proto_request_t r{};
            REQUIRE(proto_decode_request(&f, &r));
            CHECK(fields(r) == fields(to_request(v)));
        } else if (v.kind == "telemetry") {
            proto_telemetry_t t{};
            REQUIRE(proto_decode_telemetry(&f, &t));
            CHECK(fields(t) == fields(to_telemetry(v)));
        } else if (v.kind == "identity") {
            proto_identity_t i{};
            REQUIRE(proto_decode_identity(&f, &i));
            CHECK(fields(i) == fields(to_identity(v)));
        } else if (v.kind == "fault") {
            proto_fault_t ft{};
            REQUIRE(proto_decode_fault(&f, &ft));
            CHECK(fields(ft) == fields(to_fault(v)));
        } else {
            FAIL("unknown kind " << v.kind);
        }
    }
    // Every frame type has vectors.
    CHECK(kinds == std::set<std::string>{"setpoint", "config", "config_report", "request",
                                         "telemetry", "identity", "fault"});
}

TEST_CASE("frame sizes and the byte budget of docs/protocol.md", "[protocol]")
{
    CHECK(PROTO_FRAME_SIZE(PROTO_LEN_SETPOINT) == 11);
    CHECK(PROTO_FRAME_SIZE(PROTO_LEN_TELEMETRY) == 32);
    CHECK(PROTO_FRAME_SIZE(PROTO_LEN_CONFIG) == 45);
    CHECK(PROTO_FRAME_SIZE(PROTO_LEN_FAULT) == 24);
    CHECK(PROTO_MAX_FRAME == 45);
    // IDENTITY is frozen across protocol versions: any host reads any module's version.
    CHECK(PROTO_FRAME_SIZE(PROTO_LEN_IDENTITY) == 13);
    // 250000 baud at 10 bits a byte carries 2500 bytes per 10 ms period each way: the
    // telemetry frame must leave room for an identity or config report in the same period.
    CHECK(PROTO_FRAME_SIZE(PROTO_LEN_TELEMETRY) + PROTO_FRAME_SIZE(PROTO_LEN_CONFIG_REPORT) <= 2500 / 4);
}

TEST_CASE("payload length per type; unknown types have none", "[protocol]")
{
    CHECK(proto_payload_len(PROTO_T_SETPOINT) == PROTO_LEN_SETPOINT);
    CHECK(proto_payload_len(PROTO_T_CONFIG) == PROTO_LEN_CONFIG);
    CHECK(proto_payload_len(PROTO_T_REQUEST) == PROTO_LEN_REQUEST);
    CHECK(proto_payload_len(PROTO_T_TELEMETRY) == PROTO_LEN_TELEMETRY);
    CHECK(proto_payload_len(PROTO_T_IDENTITY) == PROTO_LEN_IDENTITY);
    CHECK(proto_payload_len(PROTO_T_CONFIG_REPORT) == PROTO_LEN_CONFIG_REPORT);
    CHECK(proto_payload_len(PROTO_T_FAULT) == PROTO_LEN_FAULT);
    int known = 0;
    for (int t = 0; t < 256; ++t) {
        uint8_t len = proto_payload_len(uint8_t(t));
        CHECK(len <= PROTO_MAX_PAYLOAD);
        if (len) ++known;
    }
    CHECK(known == 7);
}

TEST_CASE("decoders refuse frames of another type", "[protocol]")
{
    proto_setpoint_t sp{1, 2, 3};
    uint8_t buf[PROTO_MAX_FRAME];
    size_t n = proto_encode_setpoint(&sp, buf);
    auto frames = parse_all(std::vector<uint8_t>(buf, buf + n));
    REQUIRE(frames.size() == 1);
    proto_telemetry_t t{};
    proto_config_t c{};
    proto_identity_t i{};
    proto_request_t r{};
    proto_fault_t ft{};
    CHECK_FALSE(proto_decode_fault(&frames[0], &ft));
    CHECK_FALSE(proto_decode_telemetry(&frames[0], &t));
    CHECK_FALSE(proto_decode_config(&frames[0], &c));
    CHECK_FALSE(proto_decode_config_report(&frames[0], &c));
    CHECK_FALSE(proto_decode_identity(&frames[0], &i));
    CHECK_FALSE(proto_decode_request(&frames[0], &r));
    // A hand-built frame with the right type but a wrong length is refused too.
    proto_frame_t bad = frames[0];
    bad.len = 4;
    proto_setpoint_t s2{};
    CHECK_FALSE(proto_decode_setpoint(&bad, &s2));
}

TEST_CASE("round trip of every frame type with random and limit values", "[protocol]")
{
    std::mt19937_64 rng(20261121);
    auto u = [&](auto max) { return decltype(max)(rng() % (uint64_t(max) + 1)); };
    auto any_float = [&] {
        uint32_t b = uint32_t(rng());
        float f;
        std::memcpy(&f, &b, sizeof f);
        return f;
    };
    uint8_t buf[PROTO_MAX_FRAME];
    for (int i = 0; i < 5000; ++i) {
        proto_setpoint_t s{u(uint16_t(0xFFFF)), int16_t(u(uint16_t(0xFFFF))), u(uint8_t(0xFF))};
        size_t n = proto_encode_setpoint(&s, buf);
        REQUIRE(n == PROTO_FRAME_SIZE(PROTO_LEN_SETPOINT));
        auto s2 = decode_one<proto_setpoint_t>({buf, buf + n}, proto_decode_setpoint);
        REQUIRE(fields(s2) == fields(s));

        proto_config_t c{};
        c.module_id = u(uint8_t(0xFF));
        c.dir_sign = int8_t(u(uint8_t(0xFF)));
        c.flags = u(uint8_t(0xFF));
        c.counts_per_rev_x100 = u(uint32_t(0xFFFFFFFF));
        c.kp = any_float();
        c.ki = any_float();
        c.kd = any_float();
        c.omega_max_crpm = u(uint16_t(0xFFFF));
        c.overcurrent_ma = u(uint16_t(0xFFFF));
        c.overcurrent_samples = u(uint8_t(0xFF));
        c.undervoltage_mv = u(uint16_t(0xFFFF));
        c.undervoltage_hyst_mv = u(uint16_t(0xFFFF));
        c.motor_rated_mv = u(uint16_t(0xFFFF));
        c.cmd_timeout_ms = u(uint16_t(0xFFFF));
        c.foldback_ma = u(uint16_t(0xFFFF));
        c.stall_current_ma = u(uint16_t(0xFFFF));
        c.stall_time_ms = u(uint16_t(0xFFFF));
        c.telemetry_period_ms = u(uint8_t(0xFF));
        n = proto_encode_config(&c, buf);
        auto c2 = decode_one<proto_config_t>({buf, buf + n}, proto_decode_config);
        REQUIRE(fields(c2) == fields(c));
        n = proto_encode_config_report(&c, buf);
        auto c3 = decode_one<proto_config_t>({buf, buf + n}, proto_decode_config_report);
        REQUIRE(fields(c3) == fields(c));

        proto_telemetry_t t{};
        t.time_ms = u(uint32_t(0xFFFFFFFF));
        t.seq_ack = u(uint16_t(0xFFFF));
        t.omega_crpm = int16_t(u(uint16_t(0xFFFF)));
        t.omega_cmd_crpm = int16_t(u(uint16_t(0xFFFF)));
        t.position_counts = int32_t(u(uint32_t(0xFFFFFFFF)));
        t.current_ma = int16_t(u(uint16_t(0xFFFF)));
        t.voltage_mv = u(uint16_t(0xFFFF));
        t.duty_x10000 = int16_t(u(uint16_t(0xFFFF)));
        t.status = u(uint16_t(0xFFFF));
        t.rx_errors = u(uint16_t(0xFFFF));
        t.encoder_errors = u(uint16_t(0xFFFF));
        n = proto_encode_telemetry(&t, buf);
        auto t2 = decode_one<proto_telemetry_t>({buf, buf + n}, proto_decode_telemetry);
        REQUIRE(fields(t2) == fields(t));

        proto_identity_t id{u(uint8_t(0xFF)), u(uint8_t(0xFF)), u(uint8_t(0xFF)), u(uint8_t(0xFF)),
                            u(uint8_t(0xFF)), u(uint8_t(0xFF)), u(uint8_t(0xFF))};
        n = proto_encode_identity(&id, buf);
        auto id2 = decode_one<proto_identity_t>({buf, buf + n}, proto_decode_identity);
        REQUIRE(fields(id2) == fields(id));

        proto_fault_t ft{};
        ft.time_ms = u(uint32_t(0xFFFFFFFF));
        ft.faults = u(uint16_t(0xFFFF));
        ft.status = u(uint16_t(0xFFFF));
        ft.current_ma = int16_t(u(uint16_t(0xFFFF)));
        ft.voltage_mv = u(uint16_t(0xFFFF));
        ft.omega_crpm = int16_t(u(uint16_t(0xFFFF)));
        ft.omega_cmd_crpm = int16_t(u(uint16_t(0xFFFF)));
        ft.duty_x10000 = int16_t(u(uint16_t(0xFFFF)));
        n = proto_encode_fault(&ft, buf);
        REQUIRE(n == PROTO_FRAME_SIZE(PROTO_LEN_FAULT));
        auto ft2 = decode_one<proto_fault_t>({buf, buf + n}, proto_decode_fault);
        REQUIRE(fields(ft2) == fields(ft));

        proto_request_t r{u(uint8_t(0xFF))};
        n = proto_encode_request(&r, buf);
        auto r2 = decode_one<proto_request_t>({buf, buf + n}, proto_decode_request);
        REQUIRE(fields(r2) == fields(r));
    }
}

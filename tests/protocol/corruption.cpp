#include "corruption.hpp"

#include "protocol.h"

#include <algorithm>

namespace auger::test {

namespace {
// The check-protected part: everything after the two start bytes.
constexpr size_t kBody = 2;

// The group's link (motor_serial_interface.py) sends one XOR over the payload bytes; here it
// covers LEN, TYPE and payload, as the CRC does, so the comparison is of the checks alone.
uint8_t xor8(const uint8_t* p, size_t n)
{
    uint8_t x = 0;
    for (size_t i = 0; i < n; ++i) x ^= p[i];
    return x;
}

size_t check_size(Check c) { return c == Check::Xor8 ? 1 : 2; }
}  // namespace

std::vector<uint8_t> make_frame(Check check, uint8_t type, std::mt19937_64& rng)
{
    uint8_t len = proto_payload_len(type);
    std::vector<uint8_t> f{PROTO_START0, PROTO_START1, len, type};
    for (int i = 0; i < len; ++i) f.push_back(uint8_t(rng()));
    if (check == Check::Xor8) {
        f.push_back(xor8(f.data() + kBody, 2u + len));
    } else {
        uint16_t crc = proto_crc(f.data() + kBody, 2u + len);
        f.push_back(uint8_t(crc & 0xFF));
        f.push_back(uint8_t(crc >> 8));
    }
    return f;
}

bool accepted(Check check, const std::vector<uint8_t>& f)
{
    if (f.size() < PROTO_HEADER_SIZE + check_size(check)) return false;
    if (f[0] != PROTO_START0 || f[1] != PROTO_START1) return false;
    uint8_t len = f[2];
    if (len == 0 || len != proto_payload_len(f[3])) return false;
    if (f.size() != PROTO_HEADER_SIZE + len + check_size(check)) return false;
    const uint8_t* body = f.data() + kBody;
    if (check == Check::Xor8) return xor8(body, 2u + len) == f[PROTO_HEADER_SIZE + len];
    uint16_t crc = proto_crc(body, 2u + len);
    return f[PROTO_HEADER_SIZE + len] == (crc & 0xFF) && f[PROTO_HEADER_SIZE + len + 1] == (crc >> 8);
}

namespace {

const uint8_t kTypes[] = {PROTO_T_SETPOINT, PROTO_T_TELEMETRY, PROTO_T_CONFIG};

template <typename Corrupt>
CorruptionRow measure(const std::string& name, long trials, uint64_t seed, Corrupt corrupt)
{
    std::mt19937_64 rng(seed);
    CorruptionRow row;
    row.damage = name;
    for (long t = 0; t < trials; ++t) {
        uint8_t type = kTypes[t % 3];
        for (Check c : {Check::Xor8, Check::Crc16}) {
            auto f = make_frame(c, type, rng);
            auto bad = f;
            corrupt(bad, kBody * 8, rng);
            if (bad == f) continue;
            if (accepted(c, bad)) (c == Check::Xor8 ? row.xor_accepted : row.crc_accepted)++;
        }
        row.trials++;
    }
    return row;
}

}  // namespace

CorruptionRow measure_flips(int k, long trials, uint64_t seed)
{
    return measure(std::to_string(k) + (k == 1 ? " bit" : " bits"), trials, seed,
                   [k](std::vector<uint8_t>& f, size_t first_bit, std::mt19937_64& rng) {
                       size_t nbits = f.size() * 8 - first_bit;
                       std::vector<size_t> bits;
                       while (int(bits.size()) < k) {
                           size_t b = first_bit + rng() % nbits;
                           if (std::find(bits.begin(), bits.end(), b) == bits.end()) bits.push_back(b);
                       }
                       for (size_t b : bits) f[b / 8] ^= uint8_t(1u << (b % 8));
                   });
}

CorruptionRow measure_bursts(int min_len, int max_len, long trials, uint64_t seed)
{
    return measure("burst " + std::to_string(min_len) + "-" + std::to_string(max_len) + " bits",
                   trials, seed,
                   [=](std::vector<uint8_t>& f, size_t first_bit, std::mt19937_64& rng) {
                       size_t len = size_t(min_len) + rng() % size_t(max_len - min_len + 1);
                       size_t nbits = f.size() * 8 - first_bit;
                       size_t start = first_bit + rng() % (nbits - len + 1);
                       auto flip = [&](size_t b) { f[b / 8] ^= uint8_t(1u << (b % 8)); };
                       flip(start);
                       if (len > 1) flip(start + len - 1);
                       for (size_t b = start + 1; b + 1 < start + len; ++b)
                           if (rng() & 1) flip(b);
                   });
}

}  // namespace auger::test

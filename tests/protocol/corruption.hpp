// Measures how often a corrupted frame is accepted by the receive path with an XOR check byte
// (the research group's link) and with auger's CRC-16. Used by the test suite (exhaustive
// small cases) and by the `proto_corruption` benchmark (docs/protocol.md).
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace auger::test {

enum class Check { Xor8, Crc16 };

// A valid frame of the given type with a random payload, with either check.
std::vector<uint8_t> make_frame(Check check, uint8_t type, std::mt19937_64& rng);

// Whether the receiver accepts these exact bytes as one frame: start bytes, a length that
// matches the type, and a matching check.
bool accepted(Check check, const std::vector<uint8_t>& frame);

struct CorruptionRow {
    std::string damage;     // "1 bit", "2 bits", ..., "burst 9-16"
    long trials = 0;
    long xor_accepted = 0;  // corrupted frames the XOR check lets through
    long crc_accepted = 0;  // corrupted frames the CRC lets through
};

// Damage kinds: k random distinct bit flips (k = 1..4) after the start bytes, or bursts of
// a given length range (first and last bit flipped, the ones between random).
CorruptionRow measure_flips(int k, long trials, uint64_t seed);
CorruptionRow measure_bursts(int min_len, int max_len, long trials, uint64_t seed);

}  // namespace auger::test

// The CRC-16 catches what the paper's XOR byte misses (docs/design.md, "Serial link").
#include "corruption.hpp"
#include "protocol.h"

#include <catch2/catch.hpp>

using namespace auger::test;

TEST_CASE("CRC-16 rejects every 1, 2 and 3 bit error in a telemetry frame (exhaustive)",
          "[protocol][corruption]")
{
    std::mt19937_64 rng(7);
    auto f = make_frame(Check::Crc16, PROTO_T_TELEMETRY, rng);
    REQUIRE(accepted(Check::Crc16, f));
    const size_t first = 16, nbits = f.size() * 8;
    auto flip = [&](std::vector<uint8_t>& g, size_t b) { g[b / 8] ^= uint8_t(1u << (b % 8)); };
    long accepted_count = 0, tried = 0;
    for (size_t a = first; a < nbits; ++a) {
        auto g1 = f;
        flip(g1, a);
        accepted_count += accepted(Check::Crc16, g1);
        ++tried;
        for (size_t b = a + 1; b < nbits; ++b) {
            auto g2 = g1;
            flip(g2, b);
            accepted_count += accepted(Check::Crc16, g2);
            ++tried;
            for (size_t c = b + 1; c < nbits; c += 3) {  // a third of all triples
                auto g3 = g2;
                flip(g3, c);
                accepted_count += accepted(Check::Crc16, g3);
                ++tried;
            }
        }
    }
    INFO(tried << " corrupted frames");
    CHECK(accepted_count == 0);
}

TEST_CASE("CRC-16 rejects every burst of up to 16 bits", "[protocol][corruption]")
{
    auto row = measure_bursts(2, 16, 200000, 11);
    CHECK(row.trials == 200000);
    CHECK(row.crc_accepted == 0);
    // ... while the XOR byte lets through bursts longer than 8 bits.
    CHECK(row.xor_accepted > 0);
}

TEST_CASE("the XOR byte misses two flips in one bit column; the CRC does not",
          "[protocol][corruption]")
{
    auto row = measure_flips(2, 200000, 12);
    CHECK(row.crc_accepted == 0);
    // Two flips fall in the same bit column about 1 time in 8 after the header check.
    double share = double(row.xor_accepted) / double(row.trials);
    CHECK(share > 0.05);
    CHECK(share < 0.15);
    // An odd number of flips always changes the XOR.
    CHECK(measure_flips(1, 100000, 13).xor_accepted == 0);
    CHECK(measure_flips(3, 100000, 14).xor_accepted == 0);
}

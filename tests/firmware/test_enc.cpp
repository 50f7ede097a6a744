// Encoder decoding: transition table, counting through reversals, illegal transitions,
// extension of the ISR's 16-bit count to 32 bits.
#include <catch2/catch.hpp>

#include <climits>
#include <cstdint>

#include "enc.h"

namespace {
// The positive sequence of ab = (B << 1) | A when A leads B (docs/hardware.md):
// A rises while B is low: 00 -> A=1 (ab 1) -> B=1 (ab 3) -> A=0 (ab 2) -> 00.
const uint8_t kForward[4] = {0, 1, 3, 2};

int position_in_cycle(uint8_t ab)
{
    for (int i = 0; i < 4; ++i)
        if (kForward[i] == ab) return i;
    return -1;
}

// Expected delta derived from the cycle, independently of the table's layout.
int expected_delta(uint8_t old_ab, uint8_t new_ab)
{
    int o = position_in_cycle(old_ab), n = position_in_cycle(new_ab);
    int step = ((n - o) % 4 + 4) % 4;
    if (step == 0) return 0;
    if (step == 1) return 1;
    if (step == 3) return -1;
    return ENC_ILLEGAL;
}

void move(enc_decoder_t &d, int steps)
{
    for (int i = 0; i < (steps < 0 ? -steps : steps); ++i) {
        int p = position_in_cycle(d.ab);
        int next = steps > 0 ? (p + 1) % 4 : (p + 3) % 4;
        enc_decoder_step(&d, kForward[next]);
    }
}
} // namespace

TEST_CASE("encoder table: all 16 transitions")
{
    for (uint8_t o = 0; o < 4; ++o) {
        for (uint8_t n = 0; n < 4; ++n) {
            INFO("old " << int(o) << " new " << int(n));
            CHECK(enc_delta(o, n) == expected_delta(o, n));
        }
    }
    // A few written out, so a consistent mistake in the helper cannot hide one in the table.
    CHECK(enc_delta(0, 1) == 1);  // A rises while B low: positive
    CHECK(enc_delta(1, 0) == -1);
    CHECK(enc_delta(2, 0) == 1);  // B falls while A low: end of a positive cycle
    CHECK(enc_delta(0, 3) == ENC_ILLEGAL);
    CHECK(enc_delta(1, 2) == ENC_ILLEGAL);
    CHECK(enc_delta(3, 3) == 0);
}

TEST_CASE("encoder table: index as the ISR builds it from PIND")
{
    // PIND bit 2 = A, bit 3 = B; the ISR ORs (PIND & 0x0C) with old_ab.
    for (uint8_t o = 0; o < 4; ++o) {
        for (uint8_t n = 0; n < 4; ++n) {
            uint8_t pind = static_cast<uint8_t>(0xF3u | (n << 2)); // other pins high
            uint8_t index = static_cast<uint8_t>((pind & 0x0Cu) | o);
            CHECK(index == ENC_INDEX(o, n));
            CHECK(enc_transition_table[index] == expected_delta(o, n));
        }
    }
}

TEST_CASE("encoder table: the ISR's formula and flash layout")
{
    for (uint8_t o = 0; o < 4; ++o) {
        for (uint8_t n = 0; n < 4; ++n) {
            INFO("old " << int(o) << " new " << int(n));
            CHECK(int(ENC_DELTA(o, n)) == int(enc_transition_table[ENC_INDEX(o, n)]));
            // The ISR: prev = swap(old PIND & 0x0C), index = (PIND & 0x0C) | prev.
            uint8_t old_pind = static_cast<uint8_t>(0xF3u | (o << 2));
            uint8_t pind = static_cast<uint8_t>(0xF3u | (n << 2));
            uint8_t prev = static_cast<uint8_t>(((old_pind & 0x0Cu) << 4) | ((old_pind & 0x0Cu) >> 4));
            CHECK(uint8_t((pind & 0x0Cu) | prev) == ENC_ISR_INDEX(o, n));
        }
    }
    // 16 distinct slots
    for (unsigned a = 0; a < 16; ++a)
        for (unsigned b = a + 1; b < 16; ++b)
            CHECK(ENC_ISR_INDEX(a >> 2, a & 3) != ENC_ISR_INDEX(b >> 2, b & 3));
}

TEST_CASE("encoder decoder: counts through reversals")
{
    enc_decoder_t d;
    enc_decoder_init(&d, 0);
    move(d, 40); // ten full cycles
    CHECK(d.count == 40);
    move(d, -15);
    CHECK(d.count == 25);
    move(d, 3);
    CHECK(d.count == 28);
    // Rapid single-step reversals (dithering on one edge) cancel.
    for (int i = 0; i < 100; ++i) {
        move(d, 1);
        move(d, -1);
    }
    CHECK(d.count == 28);
    CHECK(d.illegal == 0);
}

TEST_CASE("encoder decoder: spurious interrupts with no pin change count nothing")
{
    enc_decoder_t d;
    enc_decoder_init(&d, 3);
    enc_decoder_step(&d, 3);
    enc_decoder_step(&d, 3);
    CHECK(d.count == 0);
    CHECK(d.illegal == 0);
}

TEST_CASE("encoder decoder: illegal transitions are counted, position unchanged")
{
    enc_decoder_t d;
    enc_decoder_init(&d, 0);
    move(d, 5);              // at ab = kForward[1] = 1
    enc_decoder_step(&d, 2); // 1 -> 2: both pins changed
    CHECK(d.count == 5);
    CHECK(d.illegal == 1);
    // Decoding continues from the new state.
    move(d, 1); // 2 -> 0 is +1
    CHECK(d.count == 6);
    enc_decoder_step(&d, 3); // 0 -> 3 illegal
    enc_decoder_step(&d, 0); // 3 -> 0 illegal
    CHECK(d.illegal == 3);
    CHECK(d.count == 6);
}

TEST_CASE("encoder decoder: 16-bit counts wrap")
{
    enc_decoder_t d;
    enc_decoder_init(&d, 0);
    move(d, -1);
    CHECK(d.count == 0xFFFF);
    d.illegal = 0xFFFF;
    enc_decoder_step(&d, 1); // from ab after -1 step (2): 2 -> 1 is illegal
    CHECK(d.illegal == 0);
}

TEST_CASE("encoder extension: 16-bit wrap becomes a 32-bit position")
{
    enc_extend_t x;
    enc_extend_init(&x, 65530);
    CHECK(enc_extend(&x, 65530) == 0);
    CHECK(enc_extend(&x, 5) == 11);      // forward across 0xFFFF
    CHECK(enc_extend(&x, 65526) == -4);  // back across 0 by 15
    CHECK(enc_extend(&x, 65526) == -4);
    // Many forward periods of 30000 counts: beyond the 16-bit range.
    uint16_t c = 65526;
    for (int i = 0; i < 10; ++i) {
        c = static_cast<uint16_t>(c + 30000);
        enc_extend(&x, c);
    }
    CHECK(x.position_counts == 299996);
    for (int i = 0; i < 20; ++i) {
        c = static_cast<uint16_t>(c - 30000);
        enc_extend(&x, c);
    }
    CHECK(x.position_counts == -300004);
}

TEST_CASE("encoder extension: 32-bit position wraps without overflow")
{
    enc_extend_t x;
    enc_extend_init(&x, 100);
    x.position_counts = INT32_MAX - 1;
    CHECK(enc_extend(&x, 103) == INT32_MIN + 1);
    CHECK(enc_extend(&x, 99) == INT32_MAX - 2);
}

// Parser robustness: random streams, frames between garbage, bit flips, bursts, dropped and
// duplicated bytes. The parser must never return a frame that was not sent and must recover
// every intact frame that follows the damage.
#include "protocol.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <random>
#include <vector>

namespace {

using Bytes = std::vector<uint8_t>;

// A returned frame re-serialised as it was on the wire.
Bytes wire_of(const proto_frame_t& f)
{
    Bytes wire(PROTO_FRAME_SIZE(f.len));
    wire[0] = PROTO_START0;
    wire[1] = PROTO_START1;
    wire[2] = f.len;
    wire[3] = f.type;
    std::copy(f.payload, f.payload + f.len, wire.begin() + PROTO_HEADER_SIZE);
    uint16_t crc = proto_crc(wire.data() + 2, 2u + f.len);
    wire[PROTO_HEADER_SIZE + f.len] = uint8_t(crc & 0xFF);
    wire[PROTO_HEADER_SIZE + f.len + 1] = uint8_t(crc >> 8);
    return wire;
}

struct Feed {
    proto_parser_t parser;
    std::vector<Bytes> frames;  // each returned frame, as it was on the wire

    Feed() { proto_parser_init(&parser); }

    void push(const Bytes& bytes)
    {
        proto_frame_t f;
        for (uint8_t b : bytes) {
            proto_parser_push(&parser, b);
            while (proto_parser_pop(&parser, &f)) frames.push_back(wire_of(f));
        }
    }
};

// A random valid frame of a random type.
Bytes random_frame(std::mt19937_64& rng)
{
    static const uint8_t types[] = {PROTO_T_SETPOINT, PROTO_T_CONFIG, PROTO_T_REQUEST,
                                    PROTO_T_TELEMETRY, PROTO_T_IDENTITY, PROTO_T_CONFIG_REPORT};
    uint8_t type = types[rng() % 6];
    uint8_t len = proto_payload_len(type);
    Bytes f{PROTO_START0, PROTO_START1, len, type};
    for (int i = 0; i < len; ++i) f.push_back(uint8_t(rng()));
    uint16_t crc = proto_crc(f.data() + 2, 2u + len);
    f.push_back(uint8_t(crc & 0xFF));
    f.push_back(uint8_t(crc >> 8));
    return f;
}

Bytes garbage(std::mt19937_64& rng, size_t n, bool start_heavy)
{
    Bytes g(n);
    for (auto& b : g) {
        // Garbage rich in start bytes and plausible headers is the hard case for resync.
        uint64_t r = rng() % 8;
        if (start_heavy && r == 0) b = PROTO_START0;
        else if (start_heavy && r == 1) b = PROTO_START1;
        else if (start_heavy && r == 2) b = PROTO_LEN_TELEMETRY;
        else if (start_heavy && r == 3) b = PROTO_T_TELEMETRY;
        else b = uint8_t(rng());
    }
    return g;
}

// Enough idle bytes to flush a candidate frame that garbage may have opened at the end.
const Bytes kFlush(PROTO_MAX_FRAME, 0x00);

enum class Damage { Flip1, Flip2, Flip3, Burst, Drop, Duplicate };

// Damages a copy of the frame; the damage always changes the byte sequence.
Bytes damage(const Bytes& frame, Damage d, std::mt19937_64& rng)
{
    Bytes out = frame;
    const size_t nbits = frame.size() * 8;
    auto flip = [&](size_t bit) { out[bit / 8] ^= uint8_t(1u << (bit % 8)); };
    switch (d) {
    case Damage::Flip1:
    case Damage::Flip2:
    case Damage::Flip3: {
        int k = d == Damage::Flip1 ? 1 : d == Damage::Flip2 ? 2 : 3;
        std::vector<size_t> bits;
        while (int(bits.size()) < k) {
            size_t b = rng() % nbits;
            if (std::find(bits.begin(), bits.end(), b) == bits.end()) bits.push_back(b);
        }
        for (size_t b : bits) flip(b);
        break;
    }
    case Damage::Burst: {
        // A burst of length L: first and last bit flipped, the ones between random.
        size_t len = 2 + rng() % 15;  // 2..16 bits
        size_t start = rng() % (nbits - len + 1);
        flip(start);
        flip(start + len - 1);
        for (size_t b = start + 1; b + 1 < start + len; ++b)
            if (rng() & 1) flip(b);
        break;
    }
    case Damage::Drop:
        out.erase(out.begin() + long(rng() % out.size()));
        break;
    case Damage::Duplicate: {
        size_t i = rng() % out.size();
        out.insert(out.begin() + long(i), out[i]);
        break;
    }
    }
    return out;
}

}  // namespace

TEST_CASE("a long random byte stream yields no frame", "[protocol][parser]")
{
    std::mt19937_64 rng(1);
    Feed feed;
    for (int i = 0; i < 200; ++i) feed.push(garbage(rng, 10000, i % 2 == 0));
    CHECK(feed.frames.empty());
    CHECK(feed.parser.frames_ok == 0);
    CHECK(feed.parser.bytes_discarded > 0);
}

TEST_CASE("frames between garbage are all recovered, in order", "[protocol][parser]")
{
    std::mt19937_64 rng(2);
    for (bool heavy : {false, true}) {
        Feed feed;
        std::vector<Bytes> sent;
        for (int i = 0; i < 3000; ++i) {
            feed.push(garbage(rng, rng() % (2 * PROTO_MAX_FRAME), heavy));
            sent.push_back(random_frame(rng));
            feed.push(sent.back());
        }
        feed.push(kFlush);
        REQUIRE(feed.frames.size() == sent.size());
        CHECK(feed.frames == sent);
    }
}

TEST_CASE("back-to-back frames need no gap", "[protocol][parser]")
{
    std::mt19937_64 rng(3);
    Feed feed;
    std::vector<Bytes> sent;
    for (int i = 0; i < 2000; ++i) {
        sent.push_back(random_frame(rng));
        feed.push(sent.back());
        // Each frame is returned as soon as its last byte arrives, without a flush.
        REQUIRE(feed.frames.size() == sent.size());
    }
    CHECK(feed.frames == sent);
    CHECK(feed.parser.bytes_discarded == 0);
    CHECK(proto_parser_dropped(&feed.parser) == 0);
}

// What a correct parser must return from a stream: every sent frame whose exact bytes occur
// starting inside its own stretch of the stream, taken left to right without overlap. A
// damaged frame can still occur intact: a duplicated first or last byte only adds garbage
// beside it, and a dropped last CRC byte equal to 0xA5 is replaced by the next frame's start
// byte (then that next frame is the damaged one). Returns the indices of those frames.
std::vector<size_t> frames_standing_intact(const Bytes& stream, const std::vector<size_t>& starts,
                                           const std::vector<Bytes>& originals)
{
    std::vector<size_t> out;
    size_t free_from = 0;
    for (size_t i = 0; i < originals.size(); ++i) {
        const Bytes& f = originals[i];
        size_t region_end = i + 1 < starts.size() ? starts[i + 1] : stream.size();
        for (size_t o = std::max(starts[i], free_from); o < region_end; ++o) {
            if (o + f.size() <= stream.size() &&
                std::equal(f.begin(), f.end(), stream.begin() + long(o))) {
                out.push_back(i);
                free_from = o + f.size();
                break;
            }
        }
    }
    return out;
}

TEST_CASE("damaged frames are dropped and counted; the frames after them are recovered",
          "[protocol][parser]")
{
    const Damage kinds[] = {Damage::Flip1, Damage::Flip2, Damage::Flip3,
                            Damage::Burst, Damage::Drop, Damage::Duplicate};
    const char* names[] = {"1 bit flip", "2 bit flips", "3 bit flips", "burst <= 16 bits",
                           "dropped byte", "duplicated byte"};
    for (int k = 0; k < 6; ++k) {
        SECTION(names[k])
        {
            std::mt19937_64 rng(100 + k);
            Bytes stream;
            std::vector<size_t> starts;
            std::vector<Bytes> originals;
            std::vector<bool> header_kept;  // damaged with start, length and type unchanged
            size_t intact_sent = 0;
            for (int i = 0; i < 4000; ++i) {
                Bytes f = random_frame(rng);
                starts.push_back(stream.size());
                originals.push_back(f);
                Bytes sent = f;
                if (i % 2 == 0) {
                    sent = damage(f, kinds[k], rng);
                } else {
                    ++intact_sent;
                }
                header_kept.push_back(i % 2 == 0 && std::equal(f.begin(), f.begin() + 4, sent.begin()));
                stream.insert(stream.end(), sent.begin(), sent.end());
            }
            stream.insert(stream.end(), kFlush.begin(), kFlush.end());
            auto standing = frames_standing_intact(stream, starts, originals);
            std::vector<Bytes> expected;
            size_t must_fail_crc = 0;
            for (size_t i = 0; i < originals.size(); ++i) {
                bool stands = std::find(standing.begin(), standing.end(), i) != standing.end();
                if (stands) expected.push_back(originals[i]);
                else if (header_kept[i]) ++must_fail_crc;
            }
            // The damage really damages most frames it hits (at most 15 % stay intact).
            CHECK(expected.size() >= intact_sent);
            CHECK(expected.size() <= intact_sent + intact_sent * 15 / 100);

            Feed feed;
            feed.push(stream);
            // Never a frame that was not sent, and every frame that stands intact, in order.
            CHECK(feed.frames == expected);
            // Each damaged frame whose header survived was caught by its CRC and counted.
            CHECK(feed.parser.crc_errors >= must_fail_crc);
            CHECK(must_fail_crc > 2000 / 3);  // the CRC path was really exercised
        }
    }
}

TEST_CASE("a frame split across many small reads is the same frame", "[protocol][parser]")
{
    std::mt19937_64 rng(4);
    Bytes f = random_frame(rng);
    Feed feed;
    for (uint8_t b : f) feed.push(Bytes{b});
    REQUIRE(feed.frames.size() == 1);
    CHECK(feed.frames[0] == f);
}

TEST_CASE("a wrong length for the type is a header error, not a frame", "[protocol][parser]")
{
    // A setpoint header claiming the telemetry length, with a CRC that matches the bytes.
    Bytes f{PROTO_START0, PROTO_START1, PROTO_LEN_TELEMETRY, PROTO_T_SETPOINT};
    for (unsigned i = 0; i < PROTO_LEN_TELEMETRY; ++i) f.push_back(uint8_t(i));
    uint16_t crc = proto_crc(f.data() + 2, 2u + PROTO_LEN_TELEMETRY);
    f.push_back(uint8_t(crc & 0xFF));
    f.push_back(uint8_t(crc >> 8));
    Feed feed;
    feed.push(f);
    feed.push(kFlush);
    CHECK(feed.frames.empty());
    CHECK(feed.parser.header_errors >= 1);

    // Unknown type with a plausible length.
    Bytes g{PROTO_START0, PROTO_START1, 1, 0x7E, 0x00};
    crc = proto_crc(g.data() + 2, 3);
    g.push_back(uint8_t(crc & 0xFF));
    g.push_back(uint8_t(crc >> 8));
    Feed feed2;
    feed2.push(g);
    feed2.push(kFlush);
    CHECK(feed2.frames.empty());
    CHECK(feed2.parser.header_errors >= 1);
}

TEST_CASE("a caller that never pops loses old bytes, not memory", "[protocol][parser]")
{
    proto_parser_t p;
    proto_parser_init(&p);
    for (int i = 0; i < 1000; ++i) proto_parser_push(&p, uint8_t(i));
    CHECK(p.n <= PROTO_MAX_FRAME);
    CHECK(p.bytes_discarded == 1000 - PROTO_MAX_FRAME);
}

TEST_CASE("bytes stored through proto_parser_next equal the same bytes pushed one by one",
          "[protocol][parser]")
{
    // What the module does: copy up to proto_parser_room of what has arrived (a random
    // amount here) straight into the parser, pop, repeat.
    std::mt19937_64 rng(16);
    Bytes stream;
    for (int i = 0; i < 300; ++i) {
        Bytes f = random_frame(rng);
        if (rng() % 4 == 0) f = damage(f, Damage(rng() % 6), rng);
        if (rng() % 4 == 0) {
            Bytes g = garbage(rng, rng() % 20, true);
            stream.insert(stream.end(), g.begin(), g.end());
        }
        stream.insert(stream.end(), f.begin(), f.end());
    }
    stream.insert(stream.end(), kFlush.begin(), kFlush.end());

    Feed by_byte;
    by_byte.push(stream);

    proto_parser_t p;
    proto_parser_init(&p);
    std::vector<Bytes> frames;
    size_t copies_over_1 = 0;
    size_t i = 0;
    while (i < stream.size()) {
        uint8_t room = proto_parser_room(&p);
        REQUIRE(room >= 1);
        REQUIRE(p.n + room <= PROTO_MAX_FRAME);
        size_t k = std::min<size_t>({size_t(room), stream.size() - i, 1 + rng() % 40});
        std::copy(stream.begin() + long(i), stream.begin() + long(i + k), proto_parser_next(&p));
        proto_parser_added(&p, uint8_t(k));
        i += k;
        if (k > 1) ++copies_over_1;
        proto_frame_t f;
        while (proto_parser_pop(&p, &f)) frames.push_back(wire_of(f));
    }
    CHECK(copies_over_1 > 300);
    REQUIRE(frames.size() == by_byte.frames.size());
    CHECK(frames == by_byte.frames);
    CHECK(p.n == by_byte.parser.n);
    CHECK(p.need == by_byte.parser.need);
    CHECK(p.frames_ok == by_byte.parser.frames_ok);
    CHECK(p.crc_errors == by_byte.parser.crc_errors);
    CHECK(p.header_errors == by_byte.parser.header_errors);
    CHECK(p.bytes_discarded == by_byte.parser.bytes_discarded);
    CHECK(p.crc_errors + p.header_errors > 0);  // the damaged frames were there
}

/*
 * libFuzzer target for the protocol parser (make fuzz; a bounded run is part of make test).
 * The input is fed as received bytes. Every returned frame must have the length of its type,
 * decode, and re-encode to a frame the parser returns again with the same payload; the
 * sanitizers catch any out-of-bounds access on the way.
 */
#include "protocol.h"

#include <stdlib.h>
#include <string.h>

static void check(int ok)
{
    if (!ok) abort();
}

static size_t reencode(const proto_frame_t *f, uint8_t *out)
{
    proto_setpoint_t sp;
    proto_config_t cfg;
    proto_request_t rq;
    proto_telemetry_t tm;
    proto_identity_t id;
    proto_fault_t ft;
    if (proto_decode_setpoint(f, &sp)) return proto_encode_setpoint(&sp, out);
    if (proto_decode_config(f, &cfg)) return proto_encode_config(&cfg, out);
    if (proto_decode_config_report(f, &cfg)) return proto_encode_config_report(&cfg, out);
    if (proto_decode_request(f, &rq)) return proto_encode_request(&rq, out);
    if (proto_decode_telemetry(f, &tm)) return proto_encode_telemetry(&tm, out);
    if (proto_decode_identity(f, &id)) return proto_encode_identity(&id, out);
    if (proto_decode_fault(f, &ft)) return proto_encode_fault(&ft, out);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    proto_parser_t p;
    proto_parser_init(&p);
    proto_frame_t f;
    for (size_t i = 0; i < size; ++i) {
        proto_parser_push(&p, data[i]);
        while (proto_parser_pop(&p, &f)) {
            check(f.len != 0 && f.len == proto_payload_len(f.type));
            uint8_t wire[PROTO_MAX_FRAME];
            size_t n = reencode(&f, wire);
            check(n == PROTO_FRAME_SIZE(f.len));
            proto_parser_t q;
            proto_parser_init(&q);
            proto_frame_t g;
            int got = 0;
            for (size_t k = 0; k < n; ++k) {
                proto_parser_push(&q, wire[k]);
                while (proto_parser_pop(&q, &g)) {
                    check(!got && g.type == f.type && g.len == f.len &&
                          memcmp(g.payload, f.payload, f.len) == 0);
                    got = 1;
                }
            }
            check(got);
        }
        check(p.n < PROTO_MAX_FRAME);
    }
    return 0;
}

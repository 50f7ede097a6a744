/*
 * auger serial protocol: CRC, frame packing and the byte-at-a-time parser.
 * Shared by the firmware (avr-gcc, C99) and the host (compiled as C, called from C++).
 */
#include "protocol.h"

#include <string.h>

#ifdef __AVR__
#include <util/crc16.h>
#endif

/* ---- CRC ----------------------------------------------------------------------------- */

/* The arithmetic avr-libc documents for _crc_ccitt_update: the reflected CCITT polynomial,
 * one byte per step. Static inline so that steps over constants (a frame's LEN and TYPE)
 * fold at compile time. */
static inline uint16_t crc_formula(uint16_t crc, uint8_t byte)
{
    uint8_t d = (uint8_t)(byte ^ (uint8_t)(crc & 0xFFu));
    d = (uint8_t)(d ^ (uint8_t)(d << 4));
    return (uint16_t)((((uint16_t)d << 8) | (crc >> 8)) ^ (uint8_t)(d >> 4) ^
                      (uint16_t)((uint16_t)d << 3));
}

uint16_t proto_crc_update(uint16_t crc, uint8_t byte) { return crc_formula(crc, byte); }

#ifdef __AVR__
/* On the module a table in flash: the byte step above depends on lo8(crc) ^ byte only, plus
 * hi8(crc) shifted down, so crc' = hi8(crc) ^ T[lo8(crc) ^ byte] with T[x] the step from
 * crc = 0. The 512 bytes (low bytes of T, then high bytes, 256-aligned so that the index is
 * the address's low byte) make a step of 11 cycles (17 with a loop's load and count) against
 * 24 for _crc_ccitt_update's arithmetic (docs/benchmarks.md). The values come from the same
 * formula at compile time; the host keeps the formula. */
#include <avr/pgmspace.h>

#define CRC_D(x) ((uint8_t)((x) ^ ((x) << 4)))
#define CRC_T(x) ((uint16_t)(((uint16_t)CRC_D(x) << 8) ^ (CRC_D(x) >> 4) ^ ((uint16_t)CRC_D(x) << 3)))
#define CRC_LO(x) ((uint8_t)(CRC_T(x) & 0xFFu))
#define CRC_HI(x) ((uint8_t)(CRC_T(x) >> 8))
#define CRC_R4(F, b) F(b), F(b + 1), F(b + 2), F(b + 3)
#define CRC_R16(F, b) CRC_R4(F, b), CRC_R4(F, b + 4), CRC_R4(F, b + 8), CRC_R4(F, b + 12)
#define CRC_R64(F, b) CRC_R16(F, b), CRC_R16(F, b + 16), CRC_R16(F, b + 32), CRC_R16(F, b + 48)
#define CRC_R256(F) CRC_R64(F, 0), CRC_R64(F, 64), CRC_R64(F, 128), CRC_R64(F, 192)

__attribute__((aligned(256))) static const uint8_t crc_table[512] PROGMEM = {
    CRC_R256(CRC_LO), CRC_R256(CRC_HI)
};

/* One table step on the CRC in operand c (a register pair) for the byte in register B. */
#define CRC_TABLE_STEP(B)                                                                       \
    "eor  %A[c], " B "     \n\t" /* index */                                                      \
    "mov  r30, %A[c]       \n\t"                                                                  \
    "ldi  r31, hi8(%[tab]) \n\t"                                                                  \
    "lpm  %A[c], Z         \n\t"                                                                  \
    "eor  %A[c], %B[c]     \n\t" /* lo' = hi ^ lo8(T) */                                          \
    "inc  r31              \n\t"                                                                  \
    "lpm  %B[c], Z         \n\t" /* hi' = hi8(T) */

uint16_t proto_crc(const uint8_t *data, size_t len)
{
    uint16_t c = PROTO_CRC_INIT;
    if (len == 0) return c;
    uint8_t tmp;
    __asm__ __volatile__("1: ld   %[t], X+ \n\t" CRC_TABLE_STEP("%[t]") "sbiw %[n], 1 \n\t"
                                                                       "brne 1b       \n\t"
                         : [c] "+&r"(c), [t] "=&r"(tmp), [n] "+w"(len), "+x"(data)
                         : [tab] "i"(crc_table)
                         : "r30", "r31", "memory");
    return c;
}

/* Store one byte of a frame and run it through the table: the encoders below compute the
 * CRC as they write (st X+ and 11 cycles of table step a byte, no second pass). */
static inline __attribute__((always_inline)) uint8_t *put_byte(uint8_t *p, uint16_t *crc, uint8_t byte)
{
    uint16_t c = *crc;
    __asm__ __volatile__("st   X+, %[b] \n\t" CRC_TABLE_STEP("%[b]")
                         : [c] "+&r"(c), [p] "+x"(p)
                         : [b] "r"(byte), [tab] "i"(crc_table)
                         : "r30", "r31", "memory");
    *crc = c;
    return p;
}
#else
uint16_t proto_crc(const uint8_t *data, size_t len)
{
    uint16_t crc = PROTO_CRC_INIT;
    for (size_t i = 0; i < len; ++i) {
        crc = crc_formula(crc, data[i]);
    }
    return crc;
}

static inline uint8_t *put_byte(uint8_t *p, uint16_t *crc, uint8_t byte)
{
    *p = byte;
    *crc = crc_formula(*crc, byte);
    return p + 1;
}
#endif

/* ---- little-endian packing --------------------------------------------------------------
 * In frame order, each byte going through the CRC as it is stored: the module packs a
 * telemetry frame every 10 ms (packing and CRC as two passes ~750 cycles, ~400 like this).
 * Each field names its payload offset (docs/protocol.md), checked on the host. */

typedef struct {
    uint8_t *p; /* next byte */
    uint16_t crc;
#ifndef __AVR__
    const uint8_t *payload;
#endif
} writer_t;

#ifdef __AVR__
#define AT(w, off) ((void)(off))
#else
#include <assert.h>
#define AT(w, off) ((void)(off), assert((w)->p == (w)->payload + (off)))
#endif

static inline __attribute__((always_inline)) void wr_u8(writer_t *w, uint8_t off, uint8_t v)
{
    AT(w, off);
    w->p = put_byte(w->p, &w->crc, v);
}

static inline __attribute__((always_inline)) void wr_u16(writer_t *w, uint8_t off, uint16_t v)
{
    AT(w, off);
    w->p = put_byte(w->p, &w->crc, (uint8_t)(v & 0xFFu));
    w->p = put_byte(w->p, &w->crc, (uint8_t)(v >> 8));
}

static inline __attribute__((always_inline)) void wr_u32(writer_t *w, uint8_t off, uint32_t v)
{
    wr_u16(w, off, (uint16_t)(v & 0xFFFFu));
    wr_u16(w, (uint8_t)(off + 2u), (uint16_t)(v >> 16));
}

static inline __attribute__((always_inline)) void wr_f32(writer_t *w, uint8_t off, float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    wr_u32(w, off, bits);
}

static inline uint16_t rd_u16(const uint8_t *p) { return (uint16_t)(p[0] | (uint16_t)(p[1] << 8)); }

static inline uint32_t rd_u32(const uint8_t *p)
{
    return (uint32_t)rd_u16(p) | ((uint32_t)rd_u16(p + 2) << 16);
}

static inline float rd_f32(const uint8_t *p)
{
    uint32_t bits = rd_u32(p);
    float v;
    memcpy(&v, &bits, sizeof v);
    return v;
}

/* Two's-complement reinterpretation without implementation-defined conversions. */
static inline int16_t as_i16(uint16_t v)
{
    int16_t r;
    memcpy(&r, &v, sizeof r);
    return r;
}

static inline int32_t as_i32(uint32_t v)
{
    int32_t r;
    memcpy(&r, &v, sizeof r);
    return r;
}

/* Signed to unsigned is defined (modulo 2^n); only the way back needs memcpy. */
static inline uint16_t from_i16(int16_t v) { return (uint16_t)v; }

static inline uint32_t from_i32(int32_t v) { return (uint32_t)v; }

/* ---- frames -------------------------------------------------------------------------------- */

uint8_t proto_payload_len(uint8_t type)
{
    switch (type) {
    case PROTO_T_SETPOINT: return PROTO_LEN_SETPOINT;
    case PROTO_T_CONFIG: return PROTO_LEN_CONFIG;
    case PROTO_T_REQUEST: return PROTO_LEN_REQUEST;
    case PROTO_T_TELEMETRY: return PROTO_LEN_TELEMETRY;
    case PROTO_T_IDENTITY: return PROTO_LEN_IDENTITY;
    case PROTO_T_CONFIG_REPORT: return PROTO_LEN_CONFIG_REPORT;
    case PROTO_T_FAULT: return PROTO_LEN_FAULT;
    default: return 0;
    }
}

/* Writes the header; the CRC starts over LEN and TYPE (constants: folded at compile time). */
static inline __attribute__((always_inline)) writer_t frame_begin(uint8_t *out, uint8_t type, uint8_t len)
{
    out[0] = PROTO_START0;
    out[1] = PROTO_START1;
    out[2] = len;
    out[3] = type;
    writer_t w;
    w.p = out + PROTO_HEADER_SIZE;
    w.crc = crc_formula(crc_formula(PROTO_CRC_INIT, len), type);
#ifndef __AVR__
    w.payload = w.p;
#endif
    return w;
}

/* Appends the CRC (over LEN, TYPE and payload) after the payload; returns the frame length. */
static inline __attribute__((always_inline)) size_t frame_end(writer_t *w, uint8_t len)
{
    AT(w, len);
    w->p[0] = (uint8_t)(w->crc & 0xFFu);
    w->p[1] = (uint8_t)(w->crc >> 8);
    return PROTO_FRAME_SIZE(len);
}

size_t proto_encode_setpoint(const proto_setpoint_t *sp, uint8_t *out)
{
    writer_t w = frame_begin(out, PROTO_T_SETPOINT, PROTO_LEN_SETPOINT);
    wr_u16(&w, 0, sp->seq);
    wr_u16(&w, 2, from_i16(sp->omega_crpm));
    wr_u8(&w, 4, sp->flags);
    return frame_end(&w, PROTO_LEN_SETPOINT);
}

static size_t encode_config_as(const proto_config_t *cfg, uint8_t *out, uint8_t type)
{
    writer_t w = frame_begin(out, type, PROTO_LEN_CONFIG);
    wr_u8(&w, 0, cfg->module_id);
    wr_u8(&w, 1, (uint8_t)cfg->dir_sign);
    wr_u8(&w, 2, cfg->flags);
    wr_u32(&w, 3, cfg->counts_per_rev_x100);
    wr_f32(&w, 7, cfg->kp);
    wr_f32(&w, 11, cfg->ki);
    wr_f32(&w, 15, cfg->kd);
    wr_u16(&w, 19, cfg->omega_max_crpm);
    wr_u16(&w, 21, cfg->overcurrent_ma);
    wr_u8(&w, 23, cfg->overcurrent_samples);
    wr_u16(&w, 24, cfg->undervoltage_mv);
    wr_u16(&w, 26, cfg->undervoltage_hyst_mv);
    wr_u16(&w, 28, cfg->motor_rated_mv);
    wr_u16(&w, 30, cfg->cmd_timeout_ms);
    wr_u16(&w, 32, cfg->foldback_ma);
    wr_u16(&w, 34, cfg->stall_current_ma);
    wr_u16(&w, 36, cfg->stall_time_ms);
    wr_u8(&w, 38, cfg->telemetry_period_ms);
    return frame_end(&w, PROTO_LEN_CONFIG);
}

size_t proto_encode_config(const proto_config_t *cfg, uint8_t *out)
{
    return encode_config_as(cfg, out, PROTO_T_CONFIG);
}

size_t proto_encode_config_report(const proto_config_t *cfg, uint8_t *out)
{
    return encode_config_as(cfg, out, PROTO_T_CONFIG_REPORT);
}

size_t proto_encode_request(const proto_request_t *rq, uint8_t *out)
{
    writer_t w = frame_begin(out, PROTO_T_REQUEST, PROTO_LEN_REQUEST);
    wr_u8(&w, 0, rq->what);
    return frame_end(&w, PROTO_LEN_REQUEST);
}

size_t proto_encode_telemetry(const proto_telemetry_t *tm, uint8_t *out)
{
    writer_t w = frame_begin(out, PROTO_T_TELEMETRY, PROTO_LEN_TELEMETRY);
    wr_u32(&w, 0, tm->time_ms);
    wr_u16(&w, 4, tm->seq_ack);
    wr_u16(&w, 6, from_i16(tm->omega_crpm));
    wr_u16(&w, 8, from_i16(tm->omega_cmd_crpm));
    wr_u32(&w, 10, from_i32(tm->position_counts));
    wr_u16(&w, 14, from_i16(tm->current_ma));
    wr_u16(&w, 16, tm->voltage_mv);
    wr_u16(&w, 18, from_i16(tm->duty_x10000));
    wr_u16(&w, 20, tm->status);
    wr_u16(&w, 22, tm->rx_errors);
    wr_u16(&w, 24, tm->encoder_errors);
    return frame_end(&w, PROTO_LEN_TELEMETRY);
}

size_t proto_encode_identity(const proto_identity_t *id, uint8_t *out)
{
    writer_t w = frame_begin(out, PROTO_T_IDENTITY, PROTO_LEN_IDENTITY);
    wr_u8(&w, 0, id->module_id);
    wr_u8(&w, 1, id->protocol_version);
    wr_u8(&w, 2, id->fw_major);
    wr_u8(&w, 3, id->fw_minor);
    wr_u8(&w, 4, id->fw_patch);
    wr_u8(&w, 5, id->reset_cause);
    wr_u8(&w, 6, id->flags);
    return frame_end(&w, PROTO_LEN_IDENTITY);
}

size_t proto_encode_fault(const proto_fault_t *ft, uint8_t *out)
{
    writer_t w = frame_begin(out, PROTO_T_FAULT, PROTO_LEN_FAULT);
    wr_u32(&w, 0, ft->time_ms);
    wr_u16(&w, 4, ft->faults);
    wr_u16(&w, 6, ft->status);
    wr_u16(&w, 8, from_i16(ft->current_ma));
    wr_u16(&w, 10, ft->voltage_mv);
    wr_u16(&w, 12, from_i16(ft->omega_crpm));
    wr_u16(&w, 14, from_i16(ft->omega_cmd_crpm));
    wr_u16(&w, 16, from_i16(ft->duty_x10000));
    return frame_end(&w, PROTO_LEN_FAULT);
}

/* A parser-returned frame always has the right length for its type; checking it again
 * here keeps decoders safe on frames built by hand. */
static bool frame_is(const proto_frame_t *f, uint8_t type)
{
    return f->type == type && f->len == proto_payload_len(type);
}

bool proto_decode_setpoint(const proto_frame_t *f, proto_setpoint_t *out)
{
    if (!frame_is(f, PROTO_T_SETPOINT)) return false;
    const uint8_t *p = f->payload;
    out->seq = rd_u16(p + 0);
    out->omega_crpm = as_i16(rd_u16(p + 2));
    out->flags = p[4];
    return true;
}

static void decode_config_payload(const uint8_t *p, proto_config_t *c)
{
    c->module_id = p[0];
    memcpy(&c->dir_sign, p + 1, 1);
    c->flags = p[2];
    c->counts_per_rev_x100 = rd_u32(p + 3);
    c->kp = rd_f32(p + 7);
    c->ki = rd_f32(p + 11);
    c->kd = rd_f32(p + 15);
    c->omega_max_crpm = rd_u16(p + 19);
    c->overcurrent_ma = rd_u16(p + 21);
    c->overcurrent_samples = p[23];
    c->undervoltage_mv = rd_u16(p + 24);
    c->undervoltage_hyst_mv = rd_u16(p + 26);
    c->motor_rated_mv = rd_u16(p + 28);
    c->cmd_timeout_ms = rd_u16(p + 30);
    c->foldback_ma = rd_u16(p + 32);
    c->stall_current_ma = rd_u16(p + 34);
    c->stall_time_ms = rd_u16(p + 36);
    c->telemetry_period_ms = p[38];
}

bool proto_decode_config(const proto_frame_t *f, proto_config_t *out)
{
    if (!frame_is(f, PROTO_T_CONFIG)) return false;
    decode_config_payload(f->payload, out);
    return true;
}

bool proto_decode_config_report(const proto_frame_t *f, proto_config_t *out)
{
    if (!frame_is(f, PROTO_T_CONFIG_REPORT)) return false;
    decode_config_payload(f->payload, out);
    return true;
}

bool proto_decode_request(const proto_frame_t *f, proto_request_t *out)
{
    if (!frame_is(f, PROTO_T_REQUEST)) return false;
    out->what = f->payload[0];
    return true;
}

bool proto_decode_telemetry(const proto_frame_t *f, proto_telemetry_t *out)
{
    if (!frame_is(f, PROTO_T_TELEMETRY)) return false;
    const uint8_t *p = f->payload;
    out->time_ms = rd_u32(p + 0);
    out->seq_ack = rd_u16(p + 4);
    out->omega_crpm = as_i16(rd_u16(p + 6));
    out->omega_cmd_crpm = as_i16(rd_u16(p + 8));
    out->position_counts = as_i32(rd_u32(p + 10));
    out->current_ma = as_i16(rd_u16(p + 14));
    out->voltage_mv = rd_u16(p + 16);
    out->duty_x10000 = as_i16(rd_u16(p + 18));
    out->status = rd_u16(p + 20);
    out->rx_errors = rd_u16(p + 22);
    out->encoder_errors = rd_u16(p + 24);
    return true;
}

bool proto_decode_identity(const proto_frame_t *f, proto_identity_t *out)
{
    if (!frame_is(f, PROTO_T_IDENTITY)) return false;
    const uint8_t *p = f->payload;
    out->module_id = p[0];
    out->protocol_version = p[1];
    out->fw_major = p[2];
    out->fw_minor = p[3];
    out->fw_patch = p[4];
    out->reset_cause = p[5];
    out->flags = p[6];
    return true;
}

bool proto_decode_fault(const proto_frame_t *f, proto_fault_t *out)
{
    if (!frame_is(f, PROTO_T_FAULT)) return false;
    const uint8_t *p = f->payload;
    out->time_ms = rd_u32(p + 0);
    out->faults = rd_u16(p + 4);
    out->status = rd_u16(p + 6);
    out->current_ma = as_i16(rd_u16(p + 8));
    out->voltage_mv = rd_u16(p + 10);
    out->omega_crpm = as_i16(rd_u16(p + 12));
    out->omega_cmd_crpm = as_i16(rd_u16(p + 14));
    out->duty_x10000 = as_i16(rd_u16(p + 16));
    return true;
}

/* ---- parser ---------------------------------------------------------------------------------- */

void proto_parser_init(proto_parser_t *p) { memset(p, 0, sizeof *p); }

/* Forget the first n buffered bytes; whatever stays must be checked again. */
static void drop_front(proto_parser_t *p, uint8_t n)
{
    p->n = (uint8_t)(p->n - n);
    memmove(p->buf, p->buf + n, p->n);
    p->need = 0;
}

void proto_parser_push(proto_parser_t *p, uint8_t byte)
{
    /* pop() leaves fewer than PROTO_MAX_FRAME bytes; if the caller skipped it, the
     * oldest byte cannot start a frame that still fits, so it goes. */
    if (p->n == PROTO_MAX_FRAME) {
        drop_front(p, 1);
        p->bytes_discarded++;
    }
    p->buf[p->n++] = byte;
    if (p->need) p->need--;
}

uint8_t proto_parser_room(const proto_parser_t *p)
{
    /* need > 0 only when the buffer holds a header whose frame still fits; else pop has
     * left fewer than a header's bytes: no overflow either way */
    if (p->need) return p->need;
    return p->n < PROTO_HEADER_SIZE ? (uint8_t)(PROTO_HEADER_SIZE - p->n) : 1u;
}

uint8_t *proto_parser_next(proto_parser_t *p) { return p->buf + p->n; }

void proto_parser_added(proto_parser_t *p, uint8_t k)
{
    p->n = (uint8_t)(p->n + k);
    p->need = p->need > k ? (uint8_t)(p->need - k) : 0u;
}

bool proto_parser_pop(proto_parser_t *p, proto_frame_t *out)
{
    /* A frame's body: nothing to check until its last byte (the module parses 1100 bytes/s
     * of setpoints; this keeps a body byte at a few cycles). */
    if (p->need) return false;
    for (;;) {
        if (p->n >= 1 && p->buf[0] != PROTO_START0) {
            drop_front(p, 1);
            p->bytes_discarded++;
            continue;
        }
        if (p->n >= 2 && p->buf[1] != PROTO_START1) {
            drop_front(p, 1);
            p->bytes_discarded++;
            continue;
        }
        if (p->n < PROTO_HEADER_SIZE) return false;
        uint8_t len = p->buf[2];
        uint8_t type = p->buf[3];
        if (len == 0 || len != proto_payload_len(type)) {
            /* Rescan from the byte after START0: a real frame may start inside. */
            drop_front(p, 1);
            p->header_errors++;
            p->bytes_discarded++;
            continue;
        }
        uint8_t frame_len = (uint8_t)PROTO_FRAME_SIZE(len);
        if (p->n < frame_len) {
            p->need = (uint8_t)(frame_len - p->n);
            return false;
        }
        uint16_t crc = proto_crc(p->buf + 2, 2u + len);
        if (crc != rd_u16(p->buf + PROTO_HEADER_SIZE + len)) {
            drop_front(p, 1);
            p->crc_errors++;
            p->bytes_discarded++;
            continue;
        }
        out->type = type;
        out->len = len;
        memcpy(out->payload, p->buf + PROTO_HEADER_SIZE, len);
        drop_front(p, frame_len);
        p->frames_ok++;
        return true;
    }
}

uint16_t proto_parser_dropped(const proto_parser_t *p)
{
    return (uint16_t)(p->crc_errors + p->header_errors);
}

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

uint16_t proto_crc_update(uint16_t crc, uint8_t byte)
{
#ifdef __AVR__
    return _crc_ccitt_update(crc, byte);
#else
    /* The same arithmetic as avr-libc documents for _crc_ccitt_update: the reflected
     * CCITT polynomial, one byte per step without a table (tables cost 512 bytes of flash
     * on the module and buy nothing at 100 frames/s). */
    uint8_t d = (uint8_t)(byte ^ (uint8_t)(crc & 0xFFu));
    d = (uint8_t)(d ^ (uint8_t)(d << 4));
    return (uint16_t)((((uint16_t)d << 8) | (crc >> 8)) ^ (uint8_t)(d >> 4) ^
                      (uint16_t)((uint16_t)d << 3));
#endif
}

uint16_t proto_crc(const uint8_t *data, size_t len)
{
    uint16_t crc = PROTO_CRC_INIT;
    for (size_t i = 0; i < len; ++i) {
        crc = proto_crc_update(crc, data[i]);
    }
    return crc;
}

/* ---- little-endian packing --------------------------------------------------------------- */

static void put_u8(uint8_t **p, uint8_t v) { *(*p)++ = v; }

static void put_u16(uint8_t **p, uint16_t v)
{
    put_u8(p, (uint8_t)(v & 0xFFu));
    put_u8(p, (uint8_t)(v >> 8));
}

static void put_u32(uint8_t **p, uint32_t v)
{
    put_u16(p, (uint16_t)(v & 0xFFFFu));
    put_u16(p, (uint16_t)(v >> 16));
}

static void put_f32(uint8_t **p, float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    put_u32(p, bits);
}

static uint8_t get_u8(const uint8_t **p) { return *(*p)++; }

static uint16_t get_u16(const uint8_t **p)
{
    uint16_t lo = get_u8(p);
    uint16_t hi = get_u8(p);
    return (uint16_t)(lo | (uint16_t)(hi << 8));
}

static uint32_t get_u32(const uint8_t **p)
{
    uint32_t lo = get_u16(p);
    uint32_t hi = get_u16(p);
    return lo | (hi << 16);
}

static float get_f32(const uint8_t **p)
{
    uint32_t bits = get_u32(p);
    float v;
    memcpy(&v, &bits, sizeof v);
    return v;
}

/* Two's-complement reinterpretation without implementation-defined conversions. */
static int16_t as_i16(uint16_t v)
{
    int16_t r;
    memcpy(&r, &v, sizeof r);
    return r;
}

static int32_t as_i32(uint32_t v)
{
    int32_t r;
    memcpy(&r, &v, sizeof r);
    return r;
}

static uint16_t from_i16(int16_t v)
{
    uint16_t r;
    memcpy(&r, &v, sizeof r);
    return r;
}

static uint32_t from_i32(int32_t v)
{
    uint32_t r;
    memcpy(&r, &v, sizeof r);
    return r;
}

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
    default: return 0;
    }
}

/* Writes the header, returns where the payload goes. */
static uint8_t *frame_begin(uint8_t *out, uint8_t type)
{
    out[0] = PROTO_START0;
    out[1] = PROTO_START1;
    out[2] = proto_payload_len(type);
    out[3] = type;
    return out + PROTO_HEADER_SIZE;
}

/* Appends the CRC over LEN, TYPE and payload; returns the frame length. */
static size_t frame_end(uint8_t *out)
{
    size_t len = out[2];
    uint16_t crc = proto_crc(out + 2, 2u + len);
    uint8_t *p = out + PROTO_HEADER_SIZE + len;
    put_u16(&p, crc);
    return PROTO_FRAME_SIZE(len);
}

size_t proto_encode_setpoint(const proto_setpoint_t *sp, uint8_t *out)
{
    uint8_t *p = frame_begin(out, PROTO_T_SETPOINT);
    put_u16(&p, sp->seq);
    put_u16(&p, from_i16(sp->omega_crpm));
    put_u8(&p, sp->flags);
    return frame_end(out);
}

static size_t encode_config_as(const proto_config_t *c, uint8_t *out, uint8_t type)
{
    uint8_t *p = frame_begin(out, type);
    put_u8(&p, c->module_id);
    put_u8(&p, (uint8_t)c->dir_sign);
    put_u8(&p, c->flags);
    put_u32(&p, c->counts_per_rev_x100);
    put_f32(&p, c->kp);
    put_f32(&p, c->ki);
    put_f32(&p, c->kd);
    put_u16(&p, c->omega_max_crpm);
    put_u16(&p, c->overcurrent_ma);
    put_u8(&p, c->overcurrent_samples);
    put_u16(&p, c->undervoltage_mv);
    put_u16(&p, c->undervoltage_hyst_mv);
    put_u16(&p, c->motor_rated_mv);
    put_u16(&p, c->cmd_timeout_ms);
    return frame_end(out);
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
    uint8_t *p = frame_begin(out, PROTO_T_REQUEST);
    put_u8(&p, rq->what);
    return frame_end(out);
}

size_t proto_encode_telemetry(const proto_telemetry_t *tm, uint8_t *out)
{
    uint8_t *p = frame_begin(out, PROTO_T_TELEMETRY);
    put_u32(&p, tm->time_ms);
    put_u16(&p, tm->seq_ack);
    put_u16(&p, from_i16(tm->omega_crpm));
    put_u16(&p, from_i16(tm->omega_cmd_crpm));
    put_u32(&p, from_i32(tm->position_counts));
    put_u16(&p, from_i16(tm->current_ma));
    put_u16(&p, tm->voltage_mv);
    put_u16(&p, from_i16(tm->duty_x10000));
    put_u16(&p, tm->status);
    put_u16(&p, tm->rx_errors);
    put_u16(&p, tm->encoder_errors);
    return frame_end(out);
}

size_t proto_encode_identity(const proto_identity_t *id, uint8_t *out)
{
    uint8_t *p = frame_begin(out, PROTO_T_IDENTITY);
    put_u8(&p, id->module_id);
    put_u8(&p, id->protocol_version);
    put_u8(&p, id->fw_major);
    put_u8(&p, id->fw_minor);
    put_u8(&p, id->fw_patch);
    put_u8(&p, id->reset_cause);
    put_u8(&p, id->flags);
    return frame_end(out);
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
    out->seq = get_u16(&p);
    out->omega_crpm = as_i16(get_u16(&p));
    out->flags = get_u8(&p);
    return true;
}

static void decode_config_payload(const uint8_t *p, proto_config_t *c)
{
    c->module_id = get_u8(&p);
    uint8_t dir = get_u8(&p);
    memcpy(&c->dir_sign, &dir, 1);
    c->flags = get_u8(&p);
    c->counts_per_rev_x100 = get_u32(&p);
    c->kp = get_f32(&p);
    c->ki = get_f32(&p);
    c->kd = get_f32(&p);
    c->omega_max_crpm = get_u16(&p);
    c->overcurrent_ma = get_u16(&p);
    c->overcurrent_samples = get_u8(&p);
    c->undervoltage_mv = get_u16(&p);
    c->undervoltage_hyst_mv = get_u16(&p);
    c->motor_rated_mv = get_u16(&p);
    c->cmd_timeout_ms = get_u16(&p);
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
    out->time_ms = get_u32(&p);
    out->seq_ack = get_u16(&p);
    out->omega_crpm = as_i16(get_u16(&p));
    out->omega_cmd_crpm = as_i16(get_u16(&p));
    out->position_counts = as_i32(get_u32(&p));
    out->current_ma = as_i16(get_u16(&p));
    out->voltage_mv = get_u16(&p);
    out->duty_x10000 = as_i16(get_u16(&p));
    out->status = get_u16(&p);
    out->rx_errors = get_u16(&p);
    out->encoder_errors = get_u16(&p);
    return true;
}

bool proto_decode_identity(const proto_frame_t *f, proto_identity_t *out)
{
    if (!frame_is(f, PROTO_T_IDENTITY)) return false;
    const uint8_t *p = f->payload;
    out->module_id = get_u8(&p);
    out->protocol_version = get_u8(&p);
    out->fw_major = get_u8(&p);
    out->fw_minor = get_u8(&p);
    out->fw_patch = get_u8(&p);
    out->reset_cause = get_u8(&p);
    out->flags = get_u8(&p);
    return true;
}

/* ---- parser ---------------------------------------------------------------------------------- */

void proto_parser_init(proto_parser_t *p) { memset(p, 0, sizeof *p); }

/* Forget the first n buffered bytes. */
static void drop_front(proto_parser_t *p, uint8_t n)
{
    p->n = (uint8_t)(p->n - n);
    memmove(p->buf, p->buf + n, p->n);
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
}

bool proto_parser_pop(proto_parser_t *p, proto_frame_t *out)
{
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
        if (p->n < frame_len) return false;
        uint16_t crc = proto_crc(p->buf + 2, 2u + len);
        uint16_t got = (uint16_t)(p->buf[PROTO_HEADER_SIZE + len] |
                                  (uint16_t)(p->buf[PROTO_HEADER_SIZE + len + 1] << 8));
        if (crc != got) {
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

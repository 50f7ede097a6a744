/*
 * auger serial protocol: the one definition of every frame exchanged between the host
 * (augerd, auger, tests) and a motor module (firmware). Compiled as C99 by avr-gcc and
 * as C++17 by the host; docs/protocol.md has the byte tables and a frame worked by hand.
 *
 * Frame on the wire:
 *   0xA5 0x5A | LEN | TYPE | PAYLOAD (LEN bytes) | CRC16 (little-endian)
 * CRC16 is the CCITT CRC exactly as avr-libc's _crc_ccitt_update computes it (reflected
 * polynomial 0x8408, start 0xFFFF, no final XOR; "CRC-16/MCRF4XX", check value 0x6F91)
 * over LEN, TYPE and PAYLOAD. Every type has one fixed payload length; a frame whose
 * length, type or CRC is wrong is dropped and counted, never returned.
 * All multi-byte fields are little-endian, packed with shifts (floats via memcpy to a
 * uint32_t), never by casting structs.
 */
#ifndef AUGER_PROTOCOL_H
#define AUGER_PROTOCOL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Version 2 (issue 16): CONFIG grew (current foldback, stall detection, telemetry period),
 * the FAULT frame, status bits CURRENT_LIMITED and F_STALL, identity flags for the settings'
 * origin and the reset cause decoded. A host refuses a module of another version. IDENTITY's
 * layout is frozen across versions (7 bytes, protocol_version at offset 1), so any host can
 * read any module's version and say what is wrong. */
#define PROTO_VERSION 2u

#define PROTO_START0 0xA5u
#define PROTO_START1 0x5Au
#define PROTO_HEADER_SIZE 4u /* start0, start1, len, type */
#define PROTO_CRC_SIZE 2u
#define PROTO_OVERHEAD (PROTO_HEADER_SIZE + PROTO_CRC_SIZE)

/* Bit 7 of the type says the direction: set for module -> host. */
enum proto_type {
    PROTO_T_SETPOINT = 0x01,  /* host -> module, every control period */
    PROTO_T_CONFIG = 0x02,    /* host -> module: write settings to EEPROM */
    PROTO_T_REQUEST = 0x03,   /* host -> module: ask for an identity or config report */
    PROTO_T_TELEMETRY = 0x81, /* module -> host, every control period (10 ms) */
    PROTO_T_IDENTITY = 0x82,  /* module -> host, at boot and on request */
    PROTO_T_CONFIG_REPORT = 0x83, /* module -> host: settings in use, after a config write or on request */
    PROTO_T_FAULT = 0x84          /* module -> host: the values at the moment a fault latched */
};

/* Fixed payload length of each type. */
#define PROTO_LEN_SETPOINT 5u
#define PROTO_LEN_CONFIG 39u
#define PROTO_LEN_REQUEST 1u
#define PROTO_LEN_TELEMETRY 26u
#define PROTO_LEN_IDENTITY 7u /* frozen: every protocol version */
#define PROTO_LEN_CONFIG_REPORT PROTO_LEN_CONFIG
#define PROTO_LEN_FAULT 18u

#define PROTO_MAX_PAYLOAD 39u
#define PROTO_MAX_FRAME (PROTO_OVERHEAD + PROTO_MAX_PAYLOAD)
#define PROTO_FRAME_SIZE(payload_len) (PROTO_OVERHEAD + (payload_len))

/* ---- host -> module ---------------------------------------------------------------- */

/* Setpoint flags. */
#define PROTO_SP_ENABLE 0x01u      /* drive the motor; without it the module stops (brakes) */
#define PROTO_SP_CLEAR_FAULTS 0x02u /* clear latched faults: the explicit enable after a fault */

typedef struct {
    uint16_t seq;       /* sequence number, echoed in telemetry.seq_ack once applied */
    int16_t omega_crpm; /* target screw speed, 0.01 rpm (range +-327.67 rpm) */
    uint8_t flags;      /* PROTO_SP_* */
} proto_setpoint_t;

/* Settings stored in the module's EEPROM. PID gains are in the firmware's units
 * (docs/firmware.md). Accepted only while the motor is disabled. */
typedef struct {
    uint8_t module_id;             /* 0..3 on the robot (screw index of docs/model-notes.md) */
    int8_t dir_sign;               /* +1 or -1: motor direction that counts as positive omega */
    uint8_t flags;                 /* reserved, send 0 */
    uint32_t counts_per_rev_x100;  /* encoder counts (X4) per screw revolution, x100 */
    float kp, ki, kd;              /* velocity PID gains, eqs. (23)-(24) */
    uint16_t omega_max_crpm;       /* setpoints are clamped to +-this, 0.01 rpm */
    uint16_t overcurrent_ma;       /* stop when |current| >= this ... */
    uint8_t overcurrent_samples;   /* ... for this many consecutive control periods */
    uint16_t undervoltage_mv;      /* stop below this battery voltage ... */
    uint16_t undervoltage_hyst_mv; /* ... and allow enable again only above this much more */
    uint16_t motor_rated_mv;       /* duty cap = motor_rated_mv / battery voltage */
    uint16_t cmd_timeout_ms;       /* stop when no valid setpoint for this long */
    uint16_t foldback_ma;          /* from this current up to overcurrent_ma the duty is derated
                                      linearly to 0 (0: no foldback) */
    uint16_t stall_current_ma;     /* STALL: motor current at least this (0: no detection) ... */
    uint16_t stall_time_ms;        /* ... with voltage on the motor and no rotation, this long */
    uint8_t telemetry_period_ms;   /* 10, 20, 50 or 100 */
} proto_config_t;

typedef struct {
    uint8_t what; /* the type asked for: PROTO_T_IDENTITY or PROTO_T_CONFIG_REPORT */
} proto_request_t;

/* ---- module -> host ---------------------------------------------------------------- */

/* Status word (telemetry.status, the robot log's status_N column).
 * Low byte: state; high byte: latched faults (cleared only by PROTO_SP_CLEAR_FAULTS). */
#define PROTO_ST_ENABLED 0x0001u      /* motor is being driven */
#define PROTO_ST_SETPOINT_OK 0x0002u  /* a valid setpoint arrived within the command timeout */
#define PROTO_ST_DEFAULTS 0x0004u     /* EEPROM empty or invalid: build defaults in use */
#define PROTO_ST_DUTY_LIMITED 0x0008u /* PID output at the duty cap (saturated) */
#define PROTO_ST_EEPROM_BUSY 0x0010u  /* a config write is in progress */
#define PROTO_ST_CURRENT_LIMITED 0x0020u /* current foldback derates the duty */
#define PROTO_F_CMD_TIMEOUT 0x0100u   /* no valid setpoint for cmd_timeout_ms while enabled */
#define PROTO_F_OVERCURRENT 0x0200u   /* overcurrent_samples readings >= overcurrent_ma */
#define PROTO_F_UNDERVOLTAGE 0x0400u  /* battery below undervoltage_mv */
#define PROTO_F_SENSOR 0x0800u        /* INA219 did not answer in time */
#define PROTO_F_WATCHDOG 0x1000u      /* the module was reset by its watchdog */
#define PROTO_F_STALL 0x2000u         /* voltage on the motor, current drawn, no rotation */
#define PROTO_F_MASK 0xFF00u

typedef struct {
    uint32_t time_ms;        /* module clock, ms since boot (wraps after 49.7 days) */
    uint16_t seq_ack;        /* seq of the last setpoint applied */
    int16_t omega_crpm;      /* measured screw speed, 0.01 rpm */
    int16_t omega_cmd_crpm;  /* setpoint in use after limits, 0.01 rpm */
    int32_t position_counts; /* encoder position, X4 counts (wraps) */
    int16_t current_ma;      /* motor current (INA219), signed */
    uint16_t voltage_mv;     /* battery voltage (INA219 bus voltage) */
    int16_t duty_x10000;     /* signed PWM duty, -10000..10000 */
    uint16_t status;         /* PROTO_ST_* | PROTO_F_* */
    uint16_t rx_errors;      /* frames dropped by the module (CRC, length, type, overrun), wraps */
    uint16_t encoder_errors; /* illegal encoder transitions, wraps */
} proto_telemetry_t;

typedef struct {
    uint8_t module_id;
    uint8_t protocol_version; /* PROTO_VERSION of the firmware */
    uint8_t fw_major, fw_minor, fw_patch;
    uint8_t reset_cause; /* PROTO_RC_*: why the module last started */
    uint8_t flags;       /* PROTO_ID_*: where its settings came from */
} proto_identity_t;

/* Identity flags. Without FROM_EEPROM the build defaults are in use: the EEPROM was empty,
 * or held an image of another layout (OLD_LAYOUT) or a corrupt one (CORRUPT). */
#define PROTO_ID_FROM_EEPROM 0x01u
#define PROTO_ID_SETTINGS_OLD_LAYOUT 0x02u
#define PROTO_ID_SETTINGS_CORRUPT 0x04u

/* Reset cause: bits 0..3 are the ATmega328P's MCUSR flags at boot; a bootloader (Optiboot
 * 4.4) clears MCUSR before the firmware runs, so the firmware adds what RAM still tells:
 * WATCHDOG from a marker its watchdog interrupt leaves, POWER_ON when RAM held no marker of a
 * previous run, WARM when it did but MCUSR was cleared (an external reset or a brown-out
 * through the bootloader; docs/firmware.md). */
#define PROTO_RC_POWER_ON 0x01u
#define PROTO_RC_EXTERNAL 0x02u
#define PROTO_RC_BROWN_OUT 0x04u
#define PROTO_RC_WATCHDOG 0x08u
#define PROTO_RC_WARM 0x10u

/* Sent once when faults latch: what the module measured at that moment. */
typedef struct {
    uint32_t time_ms;       /* module clock at the trip */
    uint16_t faults;        /* the PROTO_F_* bits that latched now */
    uint16_t status;        /* the whole status word after the trip */
    int16_t current_ma;     /* the INA219 reading of the trip (or the latest one) */
    uint16_t voltage_mv;
    int16_t omega_crpm;     /* measured speed, 0.01 rpm */
    int16_t omega_cmd_crpm; /* setpoint in use, 0.01 rpm */
    int16_t duty_x10000;    /* duty applied until the trip */
} proto_fault_t;

/* ---- CRC ----------------------------------------------------------------------------- */

#define PROTO_CRC_INIT 0xFFFFu
uint16_t proto_crc_update(uint16_t crc, uint8_t byte);
uint16_t proto_crc(const uint8_t *data, size_t len);

/* ---- encoding: each writes a whole frame into out (PROTO_FRAME_SIZE(len) bytes) and
 * returns its length in bytes. ------------------------------------------------------------ */

size_t proto_encode_setpoint(const proto_setpoint_t *sp, uint8_t *out);
size_t proto_encode_config(const proto_config_t *cfg, uint8_t *out);
size_t proto_encode_config_report(const proto_config_t *cfg, uint8_t *out);
size_t proto_encode_request(const proto_request_t *rq, uint8_t *out);
size_t proto_encode_telemetry(const proto_telemetry_t *tm, uint8_t *out);
size_t proto_encode_identity(const proto_identity_t *id, uint8_t *out);
size_t proto_encode_fault(const proto_fault_t *ft, uint8_t *out);

/* Payload length a type must have, or 0 for an unknown type. */
uint8_t proto_payload_len(uint8_t type);

/* ---- parsing ------------------------------------------------------------------------------ */

/* A validated frame as the parser returns it. */
typedef struct {
    uint8_t type;
    uint8_t len;
    uint8_t payload[PROTO_MAX_PAYLOAD];
} proto_frame_t;

/* Decoders: return false (and leave *out alone) if the frame is of another type. */
bool proto_decode_setpoint(const proto_frame_t *f, proto_setpoint_t *out);
bool proto_decode_config(const proto_frame_t *f, proto_config_t *out);
bool proto_decode_config_report(const proto_frame_t *f, proto_config_t *out);
bool proto_decode_request(const proto_frame_t *f, proto_request_t *out);
bool proto_decode_telemetry(const proto_frame_t *f, proto_telemetry_t *out);
bool proto_decode_identity(const proto_frame_t *f, proto_identity_t *out);
bool proto_decode_fault(const proto_frame_t *f, proto_fault_t *out);

/* Byte-at-a-time parser; no allocation, PROTO_MAX_FRAME bytes of state.
 * After a frame fails its header or CRC check, the bytes after its first start byte are
 * scanned again, so a valid frame that follows garbage is found within one frame length.
 * Counters wrap at 2^16. */
typedef struct {
    uint8_t buf[PROTO_MAX_FRAME];
    uint8_t n; /* bytes in buf */
    uint8_t need; /* bytes still to come before pop has anything to check (0: check now) */
    uint16_t frames_ok;
    uint16_t crc_errors;      /* candidate frames with a good header and a bad CRC */
    uint16_t header_errors;   /* start bytes followed by an unknown type or wrong length */
    uint16_t bytes_discarded; /* bytes skipped while looking for a frame */
} proto_parser_t;

void proto_parser_init(proto_parser_t *p);
/* Add one received byte. Then call proto_parser_pop until it returns false. */
void proto_parser_push(proto_parser_t *p, uint8_t byte);
/* The next complete valid frame, if the buffered bytes hold one. */
bool proto_parser_pop(proto_parser_t *p, proto_frame_t *out);
/* Instead of pushing byte by byte, after pop has returned false a caller may store up to
 * proto_parser_room(p) bytes at proto_parser_next(p) and report them with
 * proto_parser_added(p, k): the same as k calls of proto_parser_push, at a copy's cost (the
 * module copies a frame's header, then its body, straight out of its receive ring). The
 * room is what pop needs before it can check anything: the rest of a frame's body, else
 * the rest of a header (at least 1). */
uint8_t proto_parser_room(const proto_parser_t *p);
uint8_t *proto_parser_next(proto_parser_t *p);
void proto_parser_added(proto_parser_t *p, uint8_t k); /* k <= proto_parser_room(p) */
/* Frames dropped so far: crc_errors + header_errors (wraps). */
uint16_t proto_parser_dropped(const proto_parser_t *p);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_PROTOCOL_H */

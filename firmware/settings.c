/* Per-module settings; see settings.h. */
#include "settings.h"

#include <string.h>

#include "config.h"

void settings_defaults(proto_config_t *cfg)
{
    cfg->module_id = MODULE_ID;
    cfg->dir_sign = DIR_SIGN;
    cfg->flags = 0;
    cfg->counts_per_rev_x100 = COUNTS_PER_REV_X100;
    cfg->kp = (float)(KP);
    cfg->ki = (float)(KI);
    cfg->kd = (float)(KD);
    cfg->omega_max_crpm = OMEGA_MAX_CRPM;
    cfg->overcurrent_ma = OVERCURRENT_MA;
    cfg->overcurrent_samples = OVERCURRENT_SAMPLES;
    cfg->undervoltage_mv = UNDERVOLTAGE_MV;
    cfg->undervoltage_hyst_mv = UNDERVOLTAGE_HYST_MV;
    cfg->motor_rated_mv = MOTOR_RATED_MV;
    cfg->cmd_timeout_ms = CMD_TIMEOUT_MS;
    cfg->foldback_ma = FOLDBACK_MA;
    cfg->stall_current_ma = STALL_CURRENT_MA;
    cfg->stall_time_ms = STALL_TIME_MS;
    cfg->telemetry_period_ms = TELEMETRY_PERIOD_MS;
}

/* Finite, non-negative and small enough that eq. (24) stays finite with T = 10 ms. */
static bool gain_ok(float g)
{
    return (g - g) == 0.0f && g >= 0.0f && g <= 1.0e6f;
}

enum settings_error settings_validate(const proto_config_t *c)
{
    if (c->dir_sign != 1 && c->dir_sign != -1) return SETTINGS_E_DIR_SIGN;
    if (c->flags != 0) return SETTINGS_E_FLAGS;
    /* At least one count per revolution, at most a million. */
    if (c->counts_per_rev_x100 < 100u || c->counts_per_rev_x100 > 100000000UL)
        return SETTINGS_E_COUNTS;
    if (!gain_ok(c->kp) || !gain_ok(c->ki) || !gain_ok(c->kd)) return SETTINGS_E_GAINS;
    if (c->omega_max_crpm == 0 || c->omega_max_crpm > 32767u) return SETTINGS_E_OMEGA_MAX;
    if (c->overcurrent_ma == 0 || c->overcurrent_ma >= INA_FULL_SCALE_MA ||
        c->overcurrent_samples == 0)
        return SETTINGS_E_OVERCURRENT;
    if ((uint32_t)c->undervoltage_mv + c->undervoltage_hyst_mv >= 32000u)
        return SETTINGS_E_UNDERVOLTAGE;
    if (c->motor_rated_mv < 1000u || c->motor_rated_mv > 32000u) return SETTINGS_E_MOTOR_RATED;
    if (c->cmd_timeout_ms < 2u * CONTROL_PERIOD_MS || c->cmd_timeout_ms > 10000u)
        return SETTINGS_E_TIMEOUT;
    if (c->foldback_ma != 0 && c->foldback_ma >= c->overcurrent_ma) return SETTINGS_E_FOLDBACK;
    if (c->stall_current_ma > 32767u || c->stall_time_ms < CONTROL_PERIOD_MS || c->stall_time_ms > 2550u)
        return SETTINGS_E_STALL;
    if (c->telemetry_period_ms != 10u && c->telemetry_period_ms != 20u && c->telemetry_period_ms != 50u &&
        c->telemetry_period_ms != 100u)
        return SETTINGS_E_TELEMETRY_PERIOD;
    return SETTINGS_OK;
}

/* The payload is packed by the protocol's own encoder: one packing of the settings. */
void settings_to_image(const proto_config_t *cfg, uint8_t image[SETTINGS_IMAGE_SIZE])
{
    uint8_t frame[PROTO_FRAME_SIZE(PROTO_LEN_CONFIG)];
    proto_encode_config(cfg, frame);
    image[0] = SETTINGS_LAYOUT_VERSION;
    memcpy(image + 1, frame + PROTO_HEADER_SIZE, PROTO_LEN_CONFIG);
    uint16_t crc = proto_crc(image, 1u + PROTO_LEN_CONFIG);
    image[1 + PROTO_LEN_CONFIG] = (uint8_t)(crc & 0xFFu);
    image[2 + PROTO_LEN_CONFIG] = (uint8_t)(crc >> 8);
}

enum settings_origin settings_from_image(const uint8_t image[SETTINGS_IMAGE_SIZE], proto_config_t *cfg)
{
    if (image[0] != SETTINGS_LAYOUT_VERSION) {
        for (uint8_t i = 0; i < SETTINGS_IMAGE_SIZE; ++i)
            if (image[i] != 0xFFu) return SETTINGS_OLD_LAYOUT;
        return SETTINGS_EMPTY;
    }
    uint16_t crc = proto_crc(image, 1u + PROTO_LEN_CONFIG);
    uint16_t got = (uint16_t)(image[1 + PROTO_LEN_CONFIG] | (uint16_t)(image[2 + PROTO_LEN_CONFIG] << 8));
    if (crc != got) return SETTINGS_CORRUPT;
    proto_frame_t f;
    f.type = PROTO_T_CONFIG;
    f.len = PROTO_LEN_CONFIG;
    memcpy(f.payload, image + 1, PROTO_LEN_CONFIG);
    proto_config_t tmp;
    if (!proto_decode_config(&f, &tmp)) return SETTINGS_CORRUPT;
    if (settings_validate(&tmp) != SETTINGS_OK) return SETTINGS_CORRUPT;
    *cfg = tmp;
    return SETTINGS_FROM_IMAGE;
}

uint8_t settings_identity_flags(enum settings_origin origin)
{
    switch (origin) {
    case SETTINGS_FROM_IMAGE: return PROTO_ID_FROM_EEPROM;
    case SETTINGS_OLD_LAYOUT: return PROTO_ID_SETTINGS_OLD_LAYOUT;
    case SETTINGS_CORRUPT: return PROTO_ID_SETTINGS_CORRUPT;
    default: return 0;
    }
}

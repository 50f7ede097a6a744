/*
 * Per-module settings: build defaults (config.h), validation of a received CONFIG frame,
 * and the EEPROM image (layout version, the CONFIG payload as the protocol packs it,
 * CRC-16 of both). Called at boot and by the CONFIG frame handler.
 */
#ifndef AUGER_SETTINGS_H
#define AUGER_SETTINGS_H

#include <stdbool.h>
#include <stdint.h>

#include "protocol.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SETTINGS_LAYOUT_VERSION 1u
/* version | PROTO_LEN_CONFIG payload bytes | CRC-16 little-endian */
#define SETTINGS_IMAGE_SIZE (1u + PROTO_LEN_CONFIG + 2u)
/* EEPROM address of the image: byte 0 is the one most often corrupted by brown-outs. */
#define SETTINGS_EEPROM_ADDR 0x10u

/* Why a configuration was rejected (0: valid). */
enum settings_error {
    SETTINGS_OK = 0,
    SETTINGS_E_DIR_SIGN,
    SETTINGS_E_FLAGS,
    SETTINGS_E_COUNTS,
    SETTINGS_E_GAINS,
    SETTINGS_E_OMEGA_MAX,
    SETTINGS_E_OVERCURRENT,
    SETTINGS_E_UNDERVOLTAGE,
    SETTINGS_E_MOTOR_RATED,
    SETTINGS_E_TIMEOUT
};

void settings_defaults(proto_config_t *cfg);
enum settings_error settings_validate(const proto_config_t *cfg);
void settings_to_image(const proto_config_t *cfg, uint8_t image[SETTINGS_IMAGE_SIZE]);
/* True and *cfg filled if the image has the right version and CRC and holds valid settings. */
bool settings_from_image(const uint8_t image[SETTINGS_IMAGE_SIZE], proto_config_t *cfg);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_SETTINGS_H */

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

/* 1: protocol 1's 32-byte CONFIG payload; 2: protocol 2's 39 bytes (foldback, stall,
 * telemetry period). An image of another version is not converted: defaults, and the
 * identity says so (PROTO_ID_SETTINGS_OLD_LAYOUT). */
#define SETTINGS_LAYOUT_VERSION 2u
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
    SETTINGS_E_TIMEOUT,
    SETTINGS_E_FOLDBACK,
    SETTINGS_E_STALL,
    SETTINGS_E_TELEMETRY_PERIOD
};

/* What the EEPROM held at boot. */
enum settings_origin {
    SETTINGS_FROM_IMAGE = 0, /* a valid image of this layout: loaded */
    SETTINGS_EMPTY,          /* erased (every byte 0xFF) */
    SETTINGS_OLD_LAYOUT,     /* an image of another layout version */
    SETTINGS_CORRUPT         /* this layout, but a wrong CRC or invalid values */
};

void settings_defaults(proto_config_t *cfg);
enum settings_error settings_validate(const proto_config_t *cfg);
void settings_to_image(const proto_config_t *cfg, uint8_t image[SETTINGS_IMAGE_SIZE]);
/* SETTINGS_FROM_IMAGE and *cfg filled if the image has the right version and CRC and holds
 * valid settings; otherwise why not (*cfg untouched). */
enum settings_origin settings_from_image(const uint8_t image[SETTINGS_IMAGE_SIZE], proto_config_t *cfg);
/* The identity's PROTO_ID_* flags for an origin. */
uint8_t settings_identity_flags(enum settings_origin origin);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_SETTINGS_H */

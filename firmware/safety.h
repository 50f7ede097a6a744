/*
 * Safety state machine (DESIGN.md "Safety semantics"): the module boots disabled, drives
 * the motor only while the last valid setpoint asked for it, is fresh (cmd_timeout_ms) and
 * no fault is latched. Faults (PROTO_F_*) latch until a setpoint with
 * PROTO_SP_CLEAR_FAULTS. Under-voltage latches after UNDERVOLTAGE_SAMPLES readings in a row
 * below undervoltage_mv (a surge's sag is not an empty pack) and clears only once the battery
 * is back above undervoltage_mv + undervoltage_hyst_mv; a sensor fault only after a good
 * reading. Called from the main loop with the module time.
 */
#ifndef AUGER_SAFETY_H
#define AUGER_SAFETY_H

#include <stdbool.h>
#include <stdint.h>

#include "protocol.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    /* limits, from the settings */
    uint16_t cmd_timeout_ms;
    uint16_t overcurrent_ma;
    uint8_t overcurrent_samples;
    uint16_t undervoltage_mv;
    uint16_t undervoltage_hyst_mv;
    /* state */
    uint16_t faults;       /* PROTO_F_* latched */
    bool enable_requested; /* the last applied setpoint had PROTO_SP_ENABLE */
    bool setpoint_fresh;   /* a valid setpoint arrived within cmd_timeout_ms */
    bool battery_low;      /* below undervoltage_mv, not yet back above it + hysteresis */
    bool sensor_failing;   /* INA219 failed; cleared by the next good reading */
    uint8_t overcurrent_count; /* consecutive readings at or above the limit */
    uint8_t undervoltage_count; /* consecutive readings below undervoltage_mv */
    uint32_t last_setpoint_ms;
} safety_t;

void safety_init(safety_t *s, const proto_config_t *cfg, bool watchdog_reset);
/* New limits; the state (faults, enable) is kept. */
void safety_configure(safety_t *s, const proto_config_t *cfg);
/* A valid setpoint frame arrived at t_ms. Returns true if its speed is to be used. */
bool safety_on_setpoint(safety_t *s, uint8_t flags, uint32_t t_ms);
/* Called every tick: the command timeout. */
void safety_tick(safety_t *s, uint32_t t_ms);
/* Milliseconds from t_ms to the tick at which safety_tick detects the command timeout (0:
 * t_ms itself); UINT32_MAX without a fresh setpoint. The main loop sleeps through the
 * ticks before it. */
uint32_t safety_ms_to_timeout(const safety_t *s, uint32_t t_ms);
/* A completed INA219 reading. */
void safety_on_power(safety_t *s, int16_t current_ma, uint16_t voltage_mv);
/* The INA219 failed to answer INA_FAIL_CYCLES times in a row. */
void safety_on_sensor_fault(safety_t *s);
bool safety_motor_enabled(const safety_t *s);
/* PROTO_ST_ENABLED | PROTO_ST_SETPOINT_OK | latched PROTO_F_* bits. */
uint16_t safety_status(const safety_t *s);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_SAFETY_H */

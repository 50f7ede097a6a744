/*
 * Safety state machine (docs/design.md "Safety semantics"): the module boots disabled, drives
 * the motor only while the last valid setpoint asked for it, is fresh (cmd_timeout_ms) and
 * no fault is latched. Faults (PROTO_F_*) latch until a setpoint with
 * PROTO_SP_CLEAR_FAULTS. Under-voltage latches after UNDERVOLTAGE_SAMPLES readings in a row
 * below undervoltage_mv (a surge's sag is not an empty pack) and clears only once the battery
 * is back above undervoltage_mv + undervoltage_hyst_mv; a sensor fault only after a good
 * reading. Stall: voltage on the motor (|u| >= STALL_U_MIN of its rating), no rotation
 * (|omega| <= STALL_SPEED_CRPM) and the motor drawing stall_current_ma or more, for
 * stall_time_ms in a row, latch PROTO_F_STALL (docs/firmware.md). Called from the main loop
 * with the module time and from the control step.
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
    uint16_t stall_current_ma;  /* 0: no stall detection */
    uint8_t stall_steps;        /* control steps the stall must last */
    /* state */
    uint16_t faults;       /* PROTO_F_* latched */
    bool enable_requested; /* the last applied setpoint had PROTO_SP_ENABLE */
    bool setpoint_fresh;   /* a valid setpoint arrived within cmd_timeout_ms */
    bool battery_low;      /* below undervoltage_mv, not yet back above it + hysteresis */
    bool sensor_failing;   /* INA219 failed; cleared by the next good reading */
    uint8_t overcurrent_count; /* consecutive readings at or above the limit */
    uint8_t undervoltage_count; /* consecutive readings below undervoltage_mv */
    uint8_t stall_count;        /* consecutive control steps that looked stalled */
    uint16_t reported;          /* latched faults already handed out by safety_take_new */
    uint32_t last_setpoint_ms;
} safety_t;

void safety_init(safety_t *s, const proto_config_t *cfg, bool watchdog_reset);
/* New limits; the state (faults, enable) is kept. */
void safety_configure(safety_t *s, const proto_config_t *cfg);
/* A valid setpoint frame arrived at t_ms. Returns true if its speed is to be used. */
bool safety_on_setpoint(safety_t *s, uint8_t flags, uint32_t t_ms);
/* Called every tick: the command timeout. Returns what safety_ms_to_timeout returns after
 * it (the main loop's next wake-up, without working out the age twice). */
uint32_t safety_tick(safety_t *s, uint32_t t_ms);
/* Milliseconds from t_ms to the tick at which safety_tick detects the command timeout (0:
 * t_ms itself); UINT32_MAX without a fresh setpoint. The main loop sleeps through the
 * ticks before it. */
uint32_t safety_ms_to_timeout(const safety_t *s, uint32_t t_ms);
/* A completed INA219 reading. */
void safety_on_power(safety_t *s, int16_t current_ma, uint16_t voltage_mv);
/* The INA219 failed to answer INA_FAIL_CYCLES times in a row. */
void safety_on_sensor_fault(safety_t *s);
/* A control step with the motor driven: output u (Q27 of the rated voltage), the duty it
 * gave (1/10000), the measured speed and the latest current reading. */
void safety_on_step(safety_t *s, int32_t u_q27, int16_t duty_x10000, int16_t omega_crpm,
                    int16_t current_ma);
/* Fault bits latched since the last call (each latch is handed out once: the FAULT frame). */
uint16_t safety_take_new(safety_t *s);
__attribute__((always_inline)) static inline bool safety_motor_enabled(const safety_t *s)
{
    return s->enable_requested && s->setpoint_fresh && s->faults == 0;
}
/* PROTO_ST_ENABLED | PROTO_ST_SETPOINT_OK | latched PROTO_F_* bits. */
uint16_t safety_status(const safety_t *s);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_SAFETY_H */

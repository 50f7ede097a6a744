/* Safety state machine; see safety.h. */
#include "safety.h"

#include "config.h"
#include "pid.h"
#include "mul16.h"

#define STALL_U_MIN_Q27 ((int32_t)((int64_t)PID_U_ONE * STALL_U_MIN_PCT / 100))

void safety_configure(safety_t *s, const proto_config_t *cfg)
{
    s->cmd_timeout_ms = cfg->cmd_timeout_ms;
    s->overcurrent_ma = cfg->overcurrent_ma;
    s->overcurrent_samples = cfg->overcurrent_samples;
    s->undervoltage_mv = cfg->undervoltage_mv;
    s->undervoltage_hyst_mv = cfg->undervoltage_hyst_mv;
    s->stall_current_ma = cfg->stall_current_ma;
    /* whole control periods, rounded up; settings_validate keeps it within 1..255 */
    s->stall_steps = (uint8_t)((cfg->stall_time_ms + CONTROL_PERIOD_MS - 1u) / CONTROL_PERIOD_MS);
}

void safety_init(safety_t *s, const proto_config_t *cfg, bool watchdog_reset)
{
    safety_configure(s, cfg);
    s->faults = watchdog_reset ? PROTO_F_WATCHDOG : 0u;
    s->enable_requested = false;
    s->setpoint_fresh = false;
    s->battery_low = false;
    s->sensor_failing = false;
    s->overcurrent_count = 0;
    s->undervoltage_count = 0;
    s->stall_count = 0;
    s->reported = 0;
    s->last_setpoint_ms = 0;
}

static void latch(safety_t *s, uint16_t fault)
{
    s->faults |= fault;
    s->enable_requested = false;
}

bool safety_on_setpoint(safety_t *s, uint8_t flags, uint32_t t_ms)
{
    s->last_setpoint_ms = t_ms;
    s->setpoint_fresh = true;
    if (flags & PROTO_SP_CLEAR_FAULTS) {
        uint16_t keep = (uint16_t)((s->battery_low ? PROTO_F_UNDERVOLTAGE : 0u) |
                                   (s->sensor_failing ? PROTO_F_SENSOR : 0u));
        s->faults &= keep;
        s->reported &= keep;
        s->overcurrent_count = 0;
        s->stall_count = 0;
    }
    /* While a fault is latched a setpoint keeps the link alive but cannot enable. */
    s->enable_requested = (flags & PROTO_SP_ENABLE) && s->faults == 0;
    return s->enable_requested;
}

uint32_t safety_tick(safety_t *s, uint32_t t_ms)
{
    if (!s->setpoint_fresh) return UINT32_MAX;
    uint32_t age_ms = (uint32_t)(t_ms - s->last_setpoint_ms);
    if (age_ms >= s->cmd_timeout_ms) {
        s->setpoint_fresh = false;
        if (s->enable_requested) latch(s, PROTO_F_CMD_TIMEOUT);
        return UINT32_MAX;
    }
    return (uint32_t)s->cmd_timeout_ms - age_ms;
}

uint32_t safety_ms_to_timeout(const safety_t *s, uint32_t t_ms)
{
    if (!s->setpoint_fresh) return UINT32_MAX;
    uint32_t age_ms = (uint32_t)(t_ms - s->last_setpoint_ms);
    return age_ms >= s->cmd_timeout_ms ? 0u : (uint32_t)s->cmd_timeout_ms - age_ms;
}

void safety_on_power(safety_t *s, int16_t current_ma, uint16_t voltage_mv)
{
    s->sensor_failing = false;
    uint16_t mag = (uint16_t)(current_ma < 0 ? -(int32_t)current_ma : current_ma);
    if (mag >= s->overcurrent_ma) {
        if (s->overcurrent_count < 255u) s->overcurrent_count++;
        if (s->overcurrent_count >= s->overcurrent_samples) latch(s, PROTO_F_OVERCURRENT);
    } else {
        s->overcurrent_count = 0;
    }
    if (voltage_mv < s->undervoltage_mv) {
        if (s->undervoltage_count < 255u) s->undervoltage_count++;
        if (s->undervoltage_count >= UNDERVOLTAGE_SAMPLES) {
            s->battery_low = true;
            latch(s, PROTO_F_UNDERVOLTAGE);
        }
    } else {
        s->undervoltage_count = 0;
        if ((uint32_t)voltage_mv >= (uint32_t)s->undervoltage_mv + s->undervoltage_hyst_mv)
            s->battery_low = false;
    }
}

void safety_on_sensor_fault(safety_t *s)
{
    s->sensor_failing = true;
    latch(s, PROTO_F_SENSOR);
}

void safety_on_step(safety_t *s, int32_t u_q27, int16_t duty_x10000, int16_t omega_crpm,
                    int16_t current_ma)
{
    if (s->stall_current_ma == 0) return;
    uint32_t u_mag = (uint32_t)(u_q27 < 0 ? -u_q27 : u_q27);
    uint16_t w_mag = (uint16_t)(omega_crpm < 0 ? -(int32_t)omega_crpm : omega_crpm);
    uint16_t i_mag = (uint16_t)(current_ma < 0 ? -(int32_t)current_ma : current_ma);
    uint16_t d_mag = (uint16_t)(duty_x10000 < 0 ? -(int32_t)duty_x10000 : duty_x10000);
    /* The INA219 sits on the battery side: the pack supplies the motor current only while
     * the PWM is high, so motor current = battery current / duty; compared as products. */
    bool stalled = u_mag >= (uint32_t)STALL_U_MIN_Q27 && w_mag <= STALL_SPEED_CRPM &&
                   mul_u16(i_mag, 10000u) >= mul_u16(s->stall_current_ma, d_mag);
    if (!stalled) {
        s->stall_count = 0;
        return;
    }
    if (s->stall_count < 255u) s->stall_count++;
    if (s->stall_count >= s->stall_steps) latch(s, PROTO_F_STALL);
}

uint16_t safety_take_new(safety_t *s)
{
    uint16_t fresh = (uint16_t)(s->faults & ~s->reported);
    s->reported = s->faults;
    return fresh;
}

uint16_t safety_status(const safety_t *s)
{
    uint16_t st = s->faults;
    if (safety_motor_enabled(s)) st |= PROTO_ST_ENABLED;
    if (s->setpoint_fresh) st |= PROTO_ST_SETPOINT_OK;
    return st;
}

/*
 * Motor module main loop: one 1 kHz tick drives everything. Per tick: the command timeout
 * and the INA219 cycle start; every 10 ticks the control step (velocity, PID, PWM,
 * telemetry). Between ticks: received bytes, INA219 progress, EEPROM writes, then sleep.
 * Interrupt handlers only capture; all decisions are taken here.
 */
#include <avr/interrupt.h>
#include <string.h>

#include <avr_mcu_section.h>

#include "board.h"
#include "config.h"
#include "enc.h"
#include "ina219.h"
#include "pid.h"
#include "protocol.h"
#include "safety.h"
#include "settings.h"
#include "vel.h"

/* Tags the ELF with its chip and clock for simavr (stripped from the .hex). With -flto the
 * tags need `used`, else only the _mmcu anchor survives and simavr cannot tell the chip. */
#undef _MMCU_
#define _MMCU_ __attribute__((section(".mmcu"), used))
AVR_MCU(F_CPU, "atmega328p");

#define WDRF_BIT 3 /* MCUSR bit of a watchdog reset */

static proto_config_t settings;
static bool settings_from_eeprom;
static safety_t safety;
static pid_state_t pid;
static vel_t vel;
static enc_extend_t enc_ext;
static proto_parser_t parser;

static uint32_t t_ms;
static uint16_t seq_ack;
static int16_t omega_sp_crpm;  /* last setpoint after limits */
static int16_t omega_crpm;     /* measured */
static int32_t position_counts; /* after dir_sign */
static uint16_t encoder_errors;
static int16_t duty_x10000;    /* in omega's sign convention */
static bool duty_limited;
static ina_reading_t power;
static bool eeprom_busy;
static bool config_report_pending;
static uint8_t stack_check_steps;

static void send_identity(void)
{
    proto_identity_t id;
    id.module_id = settings.module_id;
    id.protocol_version = PROTO_VERSION;
    id.fw_major = FW_VERSION_MAJOR;
    id.fw_minor = FW_VERSION_MINOR;
    id.fw_patch = FW_VERSION_PATCH;
    id.reset_cause = fw_reset_cause;
    id.flags = settings_from_eeprom ? PROTO_ID_FROM_EEPROM : 0u;
    uint8_t buf[PROTO_FRAME_SIZE(PROTO_LEN_IDENTITY)];
    uart_write(buf, (uint8_t)proto_encode_identity(&id, buf));
}

static void send_config_report(void)
{
    uint8_t buf[PROTO_FRAME_SIZE(PROTO_LEN_CONFIG_REPORT)];
    uart_write(buf, (uint8_t)proto_encode_config_report(&settings, buf));
}

static void apply_settings(void)
{
    safety_configure(&safety, &settings);
    pid_set_gains(&pid, settings.kp, settings.ki, settings.kd, (float)(PID_T));
    vel_init(&vel, settings.counts_per_rev_x100, CONTROL_PERIOD_MS);
}

static void motor_stop(void)
{
    board_motor_set(0);
    duty_x10000 = 0;
    pid_reset(&pid);
}

static void stop_if_disabled(void)
{
    if (duty_x10000 != 0 && !safety_motor_enabled(&safety)) motor_stop();
}

static void handle_frame(const proto_frame_t *f)
{
    switch (f->type) {
    case PROTO_T_SETPOINT: {
        proto_setpoint_t sp;
        if (!proto_decode_setpoint(f, &sp)) return;
        seq_ack = sp.seq;
        int16_t lim = (int16_t)settings.omega_max_crpm;
        int16_t w = sp.omega_crpm;
        if (w > lim) w = lim;
        if (w < -lim) w = (int16_t)-lim;
        omega_sp_crpm = safety_on_setpoint(&safety, sp.flags, t_ms) ? w : 0;
        stop_if_disabled();
        break;
    }
    case PROTO_T_CONFIG: {
        proto_config_t cfg;
        if (!proto_decode_config(f, &cfg)) return;
        if (!safety_motor_enabled(&safety) && !eeprom_busy && settings_validate(&cfg) == SETTINGS_OK) {
            uint8_t image[SETTINGS_IMAGE_SIZE];
            settings = cfg;
            apply_settings();
            settings_to_image(&settings, image);
            eeprom_write_start(SETTINGS_EEPROM_ADDR, image, SETTINGS_IMAGE_SIZE);
            eeprom_busy = true;
            settings_from_eeprom = true;
            config_report_pending = true; /* sent when the write has ended */
        } else {
            send_config_report(); /* rejected: the host sees the settings still in use */
        }
        break;
    }
    case PROTO_T_REQUEST: {
        proto_request_t rq;
        if (!proto_decode_request(f, &rq)) return;
        if (rq.what == PROTO_T_IDENTITY) send_identity();
        else if (rq.what == PROTO_T_CONFIG_REPORT) send_config_report();
        break;
    }
    default:
        break;
    }
}

static int32_t with_dir_sign(int32_t raw)
{
    if (settings.dir_sign >= 0) return raw;
    uint32_t u;
    memcpy(&u, &raw, sizeof u);
    u = 0u - u; /* wraps like the counter itself */
    memcpy(&raw, &u, sizeof raw);
    return raw;
}

static void send_telemetry(void)
{
    proto_telemetry_t tm;
    tm.time_ms = t_ms;
    tm.seq_ack = seq_ack;
    tm.omega_crpm = omega_crpm;
    tm.omega_cmd_crpm = safety_motor_enabled(&safety) ? omega_sp_crpm : 0;
    tm.position_counts = position_counts;
    tm.current_ma = power.current_ma;
    tm.voltage_mv = power.voltage_mv;
    tm.duty_x10000 = duty_x10000;
    tm.status = (uint16_t)(safety_status(&safety) | (settings_from_eeprom ? 0u : PROTO_ST_DEFAULTS) |
                           (duty_limited ? PROTO_ST_DUTY_LIMITED : 0u) |
                           (eeprom_busy ? PROTO_ST_EEPROM_BUSY : 0u));
    tm.rx_errors = (uint16_t)(proto_parser_dropped(&parser) + uart_rx_overflows());
    tm.encoder_errors = encoder_errors;
    uint8_t buf[PROTO_FRAME_SIZE(PROTO_LEN_TELEMETRY)];
    uart_write(buf, (uint8_t)proto_encode_telemetry(&tm, buf));
}

/* noinline: a symbol of its own, so the simulator benchmark (bench/fw_bench) can time it
 * from call to return; one call every 10 ms costs nothing. */
__attribute__((noinline)) static void control_step(void)
{
    uint16_t count, illegal;
    board_encoder_read(&count, &illegal);
    position_counts = with_dir_sign(enc_extend(&enc_ext, count));
    encoder_errors = illegal;
    omega_crpm = vel_update_crpm(&vel, position_counts);

    bool enabled = safety_motor_enabled(&safety);
    duty_limited = false;
    if (enabled) {
        int16_t cap = pid_duty_cap_x10000(settings.motor_rated_mv, power.voltage_mv);
        duty_x10000 = pid_step_duty(&pid, (int32_t)omega_sp_crpm - omega_crpm, cap, &duty_limited);
        board_motor_set(settings.dir_sign < 0 ? (int16_t)-duty_x10000 : duty_x10000);
    } else {
        motor_stop();
    }
    board_led(enabled);
    send_telemetry();

    if (++stack_check_steps >= 100u) { /* once a second: the scan costs ~5000 cycles */
        stack_check_steps = 0;
        fw_stack_unused_bytes = board_stack_unused();
    }
}

int main(void)
{
    board_init();
    uart_init();
    ina_init();

    uint8_t image[SETTINGS_IMAGE_SIZE];
    eeprom_read_image(SETTINGS_EEPROM_ADDR, image, SETTINGS_IMAGE_SIZE);
    settings_from_eeprom = settings_from_image(image, &settings);
    if (!settings_from_eeprom) settings_defaults(&settings);
    safety_init(&safety, &settings, (fw_reset_cause & (1u << WDRF_BIT)) != 0);
    apply_settings();
    proto_parser_init(&parser);
    uint16_t count, illegal;
    board_encoder_read(&count, &illegal);
    enc_extend_init(&enc_ext, count);
    fw_stack_unused_bytes = board_stack_unused();

    board_wdt_start();
    sei();
    send_identity();

    uint8_t last_tick = board_tick;
    uint8_t phase_ms = 0;
    bool control_due = false;
    for (;;) {
        board_wdt_reset();

        uint8_t now = board_tick;
        if (now != last_tick) {
            /* Received bytes first, with t_ms still the millisecond they arrived in: the
             * same times (and so the same command timeouts) as when every byte woke the
             * loop, at one wake-up per tick with input instead of one per byte. */
            uart_rx_new = 0;
            uint8_t byte;
            while (uart_read(&byte)) {
                proto_parser_push(&parser, byte);
                proto_frame_t frame;
                while (proto_parser_pop(&parser, &frame)) handle_frame(&frame);
            }

            /* Every millisecond since the last pass, in order (the loop sleeps through the
             * ticks where none of this can change anything: see due_ms below). */
            uint8_t elapsed = (uint8_t)(now - last_tick);
            last_tick = now;
            while (elapsed--) {
                t_ms++;
                safety_tick(&safety, t_ms);
                stop_if_disabled();
                if (++phase_ms == INA_PHASE_MS) ina_start_cycle(t_ms);
                if (phase_ms >= CONTROL_PERIOD_MS) {
                    phase_ms = 0;
                    control_due = true;
                }
            }

            bool busy = eeprom_poll(); /* one byte per tick: a byte takes 3.3 ms anyway */
            if (eeprom_busy && !busy && config_report_pending) {
                config_report_pending = false;
                send_config_report();
            }
            eeprom_busy = busy;
        }

        /* Every pass: a tick, or the end of a TWI transaction (the next one starts now). */
        ina_poll(t_ms);
        ina_reading_t r;
        if (ina_take(&r)) {
            power = r;
            safety_on_power(&safety, r.current_ma, r.voltage_mv);
            stop_if_disabled();
        }
        if (ina_take_failure()) {
            safety_on_sensor_fault(&safety);
            stop_if_disabled();
        }

        if (control_due) {
            control_due = false;
            control_step();
        }

        /* The next tick with work: the INA219 cycle start (phase INA_PHASE_MS), the control
         * step (phase 0), the command timeout; every tick while an INA219 transaction (its
         * timeout is counted in ticks) or an EEPROM write is in progress. Between them the
         * tick ISR lets the loop sleep (board_idle). */
        uint8_t due_ms = (uint8_t)(phase_ms < INA_PHASE_MS ? INA_PHASE_MS - phase_ms
                                                           : CONTROL_PERIOD_MS - phase_ms);
        uint32_t timeout_ms = safety_ms_to_timeout(&safety, t_ms);
        if (timeout_ms < due_ms) due_ms = (uint8_t)timeout_ms;
        if (due_ms == 0 || eeprom_busy || ina_busy()) due_ms = 1;
        board_idle(last_tick, due_ms);
    }
}

/*
 * Motor module main loop: one 1 kHz tick drives everything. Per tick: the command timeout;
 * every 10 ticks the encoder sample and the INA219 cycle start, then with its reading the
 * control step (velocity, PID with current foldback, stall detection, PWM, telemetry every
 * telemetry_period_ms). Between ticks: received bytes, INA219 progress, EEPROM writes, then
 * sleep. Interrupt handlers only capture; all decisions are taken here.
 */
#include <avr/interrupt.h>
#include <string.h>

#include <avr_mcu_section.h>

#include "board.h"
#include "config.h"
#include "enc.h"
#include "foldback.h"
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

#define MCUSR_CAUSES 0x0Fu /* PORF, EXTRF, BORF, WDRF */
/* Left in .noinit RAM by every run: found at the next boot, RAM outlived the reset. */
#define RUN_MARKER 0xA55Au
/* Stack scan (~21 000 cycles) every 10 s: the headroom changes only with new code paths. */
#define STACK_SCAN_STEPS 1000u

__attribute__((section(".noinit"))) static uint16_t run_marker;

static proto_config_t settings;
static uint8_t settings_flags; /* PROTO_ID_* */
static uint8_t reset_cause;    /* PROTO_RC_* */
static safety_t safety;
static pid_state_t pid;
static foldback_t foldback;
static vel_t vel;
static enc_extend_t enc_ext;
static proto_parser_t parser;

/* The telemetry record is the home of the values it reports that the loop keeps anyway
 * (module time, seq_ack, measured speed, position after dir_sign, encoder errors, duty in
 * omega's sign convention): a frame copies only the rest into it. */
static proto_telemetry_t live;
static int16_t omega_sp_crpm;  /* last setpoint after limits */
static bool duty_limited;
static ina_reading_t power;
static int16_t duty_cap_x10000;  /* for power.voltage_mv (a division: only when it changes) */
static uint16_t cap_voltage_mv;
static bool eeprom_busy;
static bool config_report_pending;
static uint8_t telemetry_steps;  /* control steps per telemetry frame */
static uint8_t telemetry_count;
static uint16_t stack_check_steps;
/* The encoder as sampled at the period's tick: the control step runs when the period's
 * INA219 reading is in (a fraction of a millisecond later), the speed still over exactly
 * CONTROL_PERIOD_MS. */
static uint16_t enc_count_at_tick, enc_illegal_at_tick;

/* Why this run started: MCUSR (with the watchdog marker, encoder_isr.S); when a bootloader
 * cleared it, RAM tells a power-on (no marker of a previous run) from a warm reset. */
static uint8_t decode_reset_cause(void)
{
    uint8_t cause = (uint8_t)(fw_reset_cause & MCUSR_CAUSES);
    if (cause == 0) cause = run_marker == RUN_MARKER ? PROTO_RC_WARM : PROTO_RC_POWER_ON;
    run_marker = RUN_MARKER;
    return cause;
}

/* A frame encoded in place in the TX ring when it fits in one piece, else through a copy. */
#define SEND_FRAME(len, encode, value)                                    \
    do {                                                                  \
        uint8_t *dst_ = uart_tx_claim(len);                               \
        if (dst_) {                                                       \
            encode(value, dst_);                                          \
            uart_tx_commit(len);                                          \
        } else {                                                          \
            uint8_t buf_[len];                                            \
            uart_write(buf_, (uint8_t)encode(value, buf_));               \
        }                                                                 \
    } while (0)

static void send_identity(void)
{
    proto_identity_t id;
    id.module_id = settings.module_id;
    id.protocol_version = PROTO_VERSION;
    id.fw_major = FW_VERSION_MAJOR;
    id.fw_minor = FW_VERSION_MINOR;
    id.fw_patch = FW_VERSION_PATCH;
    id.reset_cause = reset_cause;
    id.flags = settings_flags;
    SEND_FRAME(PROTO_FRAME_SIZE(PROTO_LEN_IDENTITY), proto_encode_identity, &id);
}

static void send_config_report(void)
{
    SEND_FRAME(PROTO_FRAME_SIZE(PROTO_LEN_CONFIG_REPORT), proto_encode_config_report, &settings);
}

static void update_duty_cap(void)
{
    cap_voltage_mv = power.voltage_mv;
    duty_cap_x10000 = pid_duty_cap_x10000(settings.motor_rated_mv, cap_voltage_mv);
}

static void apply_settings(void)
{
    update_duty_cap();
    safety_configure(&safety, &settings);
    /* the under-voltage threshold and its hysteresis band: fresh samples for the filter */
    ina_watch_bus_below((uint16_t)(settings.undervoltage_mv + settings.undervoltage_hyst_mv));
    pid_set_gains(&pid, settings.kp, settings.ki, settings.kd, (float)(PID_T));
    foldback_configure(&foldback, settings.foldback_ma, settings.overcurrent_ma);
    vel_init(&vel, settings.counts_per_rev_x100, CONTROL_PERIOD_MS);
    telemetry_steps = (uint8_t)(settings.telemetry_period_ms / CONTROL_PERIOD_MS);
    telemetry_count = 0;
}

static void motor_stop(void)
{
    board_motor_set(0);
    live.duty_x10000 = 0;
    pid_reset(&pid);
    foldback_reset(&foldback);
}

static uint16_t status_word(void)
{
    return (uint16_t)(safety_status(&safety) | (settings_flags & PROTO_ID_FROM_EEPROM ? 0u : PROTO_ST_DEFAULTS) |
                      (duty_limited ? PROTO_ST_DUTY_LIMITED : 0u) | (eeprom_busy ? PROTO_ST_EEPROM_BUSY : 0u) |
                      (foldback_active(&foldback) ? PROTO_ST_CURRENT_LIMITED : 0u));
}

/* After anything that can latch a fault: stop the motor, and report new faults once with
 * what the module measured at that moment (the FAULT frame). The duty is the one applied
 * until now, so it is taken before the stop. */
static void after_safety_slow(void)
{
    uint16_t fresh = safety_take_new(&safety);
    if (fresh) {
        proto_fault_t ft;
        ft.time_ms = live.time_ms;
        ft.faults = fresh;
        ft.current_ma = power.current_ma;
        ft.voltage_mv = power.voltage_mv;
        ft.omega_crpm = live.omega_crpm;
        ft.omega_cmd_crpm = omega_sp_crpm;
        ft.duty_x10000 = live.duty_x10000;
        if (live.duty_x10000 != 0 && !safety_motor_enabled(&safety)) motor_stop();
        ft.status = status_word();
        SEND_FRAME(PROTO_FRAME_SIZE(PROTO_LEN_FAULT), proto_encode_fault, &ft);
    } else if (live.duty_x10000 != 0 && !safety_motor_enabled(&safety)) {
        motor_stop();
    }
}

/* Called after every safety event on every pass: the common case (nothing new, the motor
 * as it should be) in a few cycles. */
__attribute__((always_inline)) static inline void after_safety(void)
{
    if (safety.faults != safety.reported || (live.duty_x10000 != 0 && !safety_motor_enabled(&safety)))
        after_safety_slow();
}

static void handle_frame(const proto_frame_t *f)
{
    switch (f->type) {
    case PROTO_T_SETPOINT: {
        proto_setpoint_t sp;
        if (!proto_decode_setpoint(f, &sp)) return;
        live.seq_ack = sp.seq;
        int16_t lim = (int16_t)settings.omega_max_crpm;
        int16_t w = sp.omega_crpm;
        if (w > lim) w = lim;
        if (w < -lim) w = (int16_t)-lim;
        omega_sp_crpm = safety_on_setpoint(&safety, sp.flags, live.time_ms) ? w : 0;
        after_safety();
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
            settings_flags = PROTO_ID_FROM_EEPROM;
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

__attribute__((noinline)) static void send_telemetry(void)
{
    live.omega_cmd_crpm = safety_motor_enabled(&safety) ? omega_sp_crpm : 0;
    live.current_ma = power.current_ma;
    live.voltage_mv = power.voltage_mv;
    live.status = status_word();
    live.rx_errors = (uint16_t)(proto_parser_dropped(&parser) + uart_rx_overflows());
    SEND_FRAME(PROTO_FRAME_SIZE(PROTO_LEN_TELEMETRY), proto_encode_telemetry, &live);
}

/* noinline: a symbol of its own, so the simulator benchmark (bench/fw_bench) can time it
 * from call to return; one call every 10 ms costs nothing. */
__attribute__((noinline)) static void control_step(void)
{
    live.position_counts = with_dir_sign(enc_extend(&enc_ext, enc_count_at_tick));
    live.encoder_errors = enc_illegal_at_tick;
    live.omega_crpm = vel_update_crpm(&vel, live.position_counts);

    bool enabled = safety_motor_enabled(&safety);
    duty_limited = false;
    if (enabled) {
        int32_t limit = foldback_update(&foldback, power.current_ma, pid.u);
        int32_t u;
        live.duty_x10000 = pid_step_duty(&pid, (int32_t)omega_sp_crpm - live.omega_crpm, duty_cap_x10000, limit,
                                    &duty_limited, &u);
        /* the clamp at the foldback limit is the current limit's, not the duty cap's */
        if (limit < PID_U_ONE && (u == limit || u == -limit)) duty_limited = false;
        safety_on_step(&safety, u, live.duty_x10000, live.omega_crpm, power.current_ma);
        after_safety();
        if (live.duty_x10000 != 0 || safety_motor_enabled(&safety))
            board_motor_set(settings.dir_sign < 0 ? (int16_t)-live.duty_x10000 : live.duty_x10000);
    } else {
        motor_stop();
    }
    board_led(enabled);
    if (++telemetry_count >= telemetry_steps) {
        telemetry_count = 0;
        send_telemetry();
    }

    if (++stack_check_steps >= STACK_SCAN_STEPS) {
        stack_check_steps = 0;
        fw_stack_unused_bytes = board_stack_unused();
    }
}

int main(void)
{
    board_init();
    uart_init();
    ina_init();
    reset_cause = decode_reset_cause();

    uint8_t image[SETTINGS_IMAGE_SIZE];
    eeprom_read_image(SETTINGS_EEPROM_ADDR, image, SETTINGS_IMAGE_SIZE);
    enum settings_origin origin = settings_from_image(image, &settings);
    if (origin != SETTINGS_FROM_IMAGE) settings_defaults(&settings);
    settings_flags = settings_identity_flags(origin);
    safety_init(&safety, &settings, (reset_cause & PROTO_RC_WATCHDOG) != 0);
    safety_take_new(&safety); /* a watchdog fault at boot: the identity says it */
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
    uint8_t wake_ms = 1; /* ticks from last_tick to the next tick with work (below) */
    /* ms to the command timeout as of the last safety_tick, counted down between calls:
     * the timeout moves only with a frame (a setpoint, a CONFIG), so safety_tick runs on
     * the passes that handled one and when the count runs out (the tick it would detect
     * the timeout at), not on every tick pass. UINT16_MAX: no fresh setpoint. */
    uint16_t timeout_left_ms = 0;
    bool control_due = false;
    for (;;) {
        board_wdt_reset();

        uint8_t now = board_tick;
        if (now != last_tick) {
            /* Received bytes first, with the module time still the millisecond they arrived in: the
             * same times (and so the same command timeouts) as when every byte woke the
             * loop, at one wake-up per tick with input instead of one per byte. */
            /* A header, then a body, each in one copy out of the ring (byte by byte through
             * a read and proto_parser_push a setpoint cost ~45 cycles a byte). The RX ISR
             * sets uart_rx_new with every byte it stores: without it the ring is empty. */
            bool framed = false;
            if (uart_rx_new) {
                uart_rx_new = 0;
                uint8_t got;
                while ((got = uart_read_some(proto_parser_next(&parser), proto_parser_room(&parser))) != 0) {
                    proto_parser_added(&parser, got);
                    if (parser.need) continue; /* inside a frame's body: nothing to check yet */
                    proto_frame_t frame;
                    while (proto_parser_pop(&parser, &frame)) {
                        handle_frame(&frame);
                        framed = true;
                    }
                }
            }

            /* The milliseconds since the last pass at once: the loop sleeps through ticks
             * where nothing can change (due_ms below), so the command timeout and the phase
             * events fall on the pass that woke for them. */
            uint8_t elapsed = (uint8_t)(now - last_tick);
            last_tick = now;
            live.time_ms += elapsed;
            if (framed || elapsed >= timeout_left_ms) {
                uint32_t timeout_ms = safety_tick(&safety, live.time_ms);
                if (timeout_ms == UINT32_MAX) {
                    timeout_left_ms = UINT16_MAX;
                    after_safety(); /* the only case it can have changed anything */
                } else {
                    timeout_left_ms = (uint16_t)timeout_ms; /* <= cmd_timeout_ms */
                }
            } else {
                timeout_left_ms = (uint16_t)(timeout_left_ms - elapsed);
            }
            if (control_due) {
                /* A tick and the period's INA219 cycle has not ended (a sensor that does not
                 * answer: its transaction times out after TWI_TIMEOUT_MS): step without it. */
                control_due = false;
                control_step();
            }
            phase_ms = (uint8_t)(phase_ms + elapsed);
            if (phase_ms >= CONTROL_PERIOD_MS) {
                /* (more than a period late only if the loop was held up that long) */
                while (phase_ms >= CONTROL_PERIOD_MS) phase_ms = (uint8_t)(phase_ms - CONTROL_PERIOD_MS);
                /* The period starts: sample the encoder, start the INA219 cycle; the control
                 * step follows on the pass that takes the reading (0.1-0.75 ms later), so it
                 * acts on a current a fraction of a millisecond old, and the cycle's start
                 * needs no tick pass of its own. */
                board_encoder_read(&enc_count_at_tick, &enc_illegal_at_tick);
                ina_start_cycle(live.time_ms, live.duty_x10000 != 0);
                control_due = true;
            }

            if (eeprom_busy || config_report_pending) {
                bool busy = eeprom_poll(); /* one byte per tick: a byte takes 3.3 ms anyway */
                if (eeprom_busy && !busy && config_report_pending) {
                    config_report_pending = false;
                    send_config_report();
                }
                eeprom_busy = busy;
            }

            /* The next tick with work: the period's start (phase 0), the command timeout.
             * Only this block moves the phase and the setpoint's age, so the passes between
             * ticks (the ends of TWI transactions) keep the figure. */
            wake_ms = (uint8_t)(CONTROL_PERIOD_MS - phase_ms);
            if (timeout_left_ms < wake_ms) wake_ms = (uint8_t)timeout_left_ms;
            if (wake_ms == 0) wake_ms = 1;
        }

        /* Every pass: a tick, or the end of a TWI transaction (the next one starts now). */
        if (ina_busy()) {
            ina_poll(live.time_ms);
            ina_reading_t r;
            if (ina_take(&r)) {
                power = r;
                if (power.voltage_mv != cap_voltage_mv) update_duty_cap();
                safety_on_power(&safety, r.current_ma, r.voltage_mv);
                after_safety();
            }
            if (ina_take_failure()) {
                safety_on_sensor_fault(&safety);
                after_safety();
            }
        }

        if (control_due && !ina_busy()) {
            control_due = false;
            control_step();
        }

        /* Every tick while an INA219 transaction (its timeout is counted in ticks) or an
         * EEPROM write is in progress. Between the ticks with work the tick ISR lets the
         * loop sleep (board_idle). */
        board_idle(last_tick, eeprom_busy || ina_busy() ? 1 : wake_ms);
    }
}

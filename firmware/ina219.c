/* INA219 driver; see ina219.h. */
#include "ina219.h"

#include "board.h"
#include "config.h"
#include "ina_math.h"

enum step { STEP_IDLE, STEP_CHECK, STEP_CONFIG, STEP_CAL, STEP_BUS, STEP_CURRENT };

static uint8_t step = STEP_IDLE;
static bool configured;
/* The chip was found reset this cycle: its current register predates the new calibration
 * (it is updated at the end of a conversion), so this cycle reports no new current. */
static bool reset_seen;
static bool have_values;  /* bus voltage and current of this cycle are read */
static bool checked;      /* the configuration was read back this cycle */
static bool driven;       /* the motor is driven this cycle */
static uint8_t since_verify;
static uint8_t bus_wait;  /* cycles until the bus voltage is read again (INA_BUS_CYCLES) */
static uint16_t bus_watch_mv; /* below this, the bus voltage is read every cycle */
static uint32_t step_start_ms;
static uint8_t tx[3];
static uint8_t rx[2];
static uint16_t bus_reg, current_reg;
static ina_reading_t latest;
static bool have_new;
static uint8_t fail_streak;
static bool failure_pending;

static void launch(uint8_t s, uint32_t t_ms)
{
    step = s;
    step_start_ms = t_ms;
    uint8_t wlen = 1, rlen = 2;
    switch (s) {
    case STEP_CHECK:
        /* A load transient can reset the chip: configuration (range, averaging) and
         * calibration back to their power-on values (the current then reads 0). */
        tx[0] = INA_REG_CONFIG;
        break;
    case STEP_CONFIG:
        tx[0] = INA_REG_CONFIG;
        tx[1] = (uint8_t)(INA_CONFIG_VALUE >> 8);
        tx[2] = (uint8_t)(INA_CONFIG_VALUE & 0xFFu);
        wlen = 3;
        rlen = 0;
        break;
    case STEP_CAL:
        tx[0] = INA_REG_CAL;
        tx[1] = (uint8_t)(INA_CAL >> 8);
        tx[2] = (uint8_t)(INA_CAL & 0xFFu);
        wlen = 3;
        rlen = 0;
        break;
    case STEP_BUS:
        tx[0] = INA_REG_BUS;
        break;
    default:
        tx[0] = INA_REG_CURRENT;
        break;
    }
    if (!twi_start(INA_ADDR, tx, wlen, rx, rlen)) step = STEP_IDLE; /* cannot happen: a cycle owns the bus */
}

static void fail_cycle(void)
{
    step = STEP_IDLE;
    configured = false; /* the chip may have reset: configure it again */
    if (fail_streak < 255u) fail_streak++;
    if (fail_streak >= INA_FAIL_CYCLES) failure_pending = true;
}

static void deliver(void)
{
    latest.voltage_mv = ina_bus_mv(bus_reg); /* the latest bus reading */
    if (!reset_seen) latest.current_ma = ina_current_ma(current_reg, CURRENT_LSB_UA);
    reset_seen = false;
    have_new = true;
    fail_streak = 0;
    step = STEP_IDLE;
}

void ina_init(void)
{
    twi_init();
    step = STEP_IDLE;
    configured = false;
    fail_streak = 0;
}

void ina_watch_bus_below(uint16_t mv) { bus_watch_mv = mv; }

void ina_start_cycle(uint32_t t_ms, bool motor_driven)
{
    if (step != STEP_IDLE) {
        /* The previous cycle never finished. */
        twi_abort();
        fail_cycle();
    }
    driven = motor_driven;
    have_values = false;
    checked = false;
    if (!configured) {
        since_verify = 0;
        launch(STEP_CONFIG, t_ms);
    } else if (++since_verify >= INA_VERIFY_CYCLES) {
        since_verify = 0;
        checked = true;
        launch(STEP_CHECK, t_ms);
    } else {
        /* The battery voltage moves slowly (its sag under a current surge lasts as long as
         * the surge): every INA_BUS_CYCLES-th cycle serves the duty cap and finds a low pack
         * within INA_BUS_CYCLES periods, after which (below bus_watch_mv) every reading is
         * fresh, so the under-voltage filter counts real samples; a transaction (7
         * interrupts) saved in the other cycles. */
        bool bus = bus_wait == 0 || latest.voltage_mv < bus_watch_mv;
        bus_wait = bus ? (uint8_t)(INA_BUS_CYCLES - 1u) : (uint8_t)(bus_wait - 1u);
        launch(bus ? STEP_BUS : STEP_CURRENT, t_ms);
    }
}

void ina_poll(uint32_t t_ms)
{
    if (step == STEP_IDLE) return;
    enum twi_status st = twi_status();
    if (st == TWI_BUSY || st == TWI_IDLE) {
        if ((uint32_t)(t_ms - step_start_ms) > TWI_TIMEOUT_MS) {
            twi_abort();
            fail_cycle();
        }
        return;
    }
    twi_acknowledge();
    if (st == TWI_ERROR) {
        fail_cycle();
        return;
    }
    switch (step) {
    case STEP_CHECK:
        if ((uint16_t)(((uint16_t)rx[0] << 8) | rx[1]) == INA_CONFIG_VALUE) {
            /* Intact: the calibration is rewritten all the same on the periodic check (a
             * single upset register); after a current of 0 it was right, so deliver. */
            if (have_values) deliver();
            else launch(STEP_CAL, t_ms);
        } else {
            reset_seen = true;
            launch(STEP_CONFIG, t_ms);
        }
        break;
    case STEP_CONFIG:
        configured = true;
        launch(STEP_CAL, t_ms);
        break;
    case STEP_CAL:
        if (have_values) deliver();
        else launch(STEP_BUS, t_ms);
        break;
    case STEP_BUS:
        bus_reg = (uint16_t)(((uint16_t)rx[0] << 8) | rx[1]);
        launch(STEP_CURRENT, t_ms);
        break;
    default:
        current_reg = (uint16_t)(((uint16_t)rx[0] << 8) | rx[1]);
        have_values = true;
        if (current_reg == 0 && driven && !checked) {
            /* A reset chip (calibration 0) reads exactly 0: look now, not at the next
             * periodic check, so a stalled motor is never hidden for long. */
            checked = true;
            launch(STEP_CHECK, t_ms);
        } else {
            deliver();
        }
        break;
    }
}

bool ina_busy(void) { return step != STEP_IDLE; }

bool ina_take(ina_reading_t *out)
{
    if (!have_new) return false;
    *out = latest;
    have_new = false;
    return true;
}

bool ina_take_failure(void)
{
    bool f = failure_pending;
    failure_pending = false;
    return f;
}

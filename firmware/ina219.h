/*
 * INA219 driver: a non-blocking cycle (current read, and the bus voltage every
 * INA_BUS_CYCLES-th cycle, every cycle while the pack is low: ina_watch_bus_below)
 * started once per control period and advanced from the main loop over the interrupt-driven
 * TWI master.
 * Every INA_VERIFY_CYCLES cycles it first reads the configuration back and rewrites the
 * calibration; a current of exactly 0 with the motor driven (what a chip reset to its
 * power-on values reads) triggers that check in the same cycle. Every transaction has a
 * timeout.
 */
#ifndef AUGER_INA219_H
#define AUGER_INA219_H

#include <stdbool.h>
#include <stdint.h>

typedef struct {
    uint16_t voltage_mv;
    int16_t current_ma;
} ina_reading_t;

void ina_init(void);
/* While the last bus reading is below mv the bus voltage is read every cycle, not every
 * INA_BUS_CYCLES-th (the under-voltage filter then counts fresh samples). */
void ina_watch_bus_below(uint16_t mv);
/* motor_driven: a current of 0 would be implausible (a reset chip reads 0). */
void ina_start_cycle(uint32_t t_ms, bool motor_driven);
void ina_poll(uint32_t t_ms);
/* A cycle is in progress (a transaction or its timeout to watch). */
bool ina_busy(void);
/* A complete new reading since the last call. */
bool ina_take(ina_reading_t *out);
/* True once each time a cycle fails with INA_FAIL_CYCLES or more failures in a row. */
bool ina_take_failure(void);

#endif /* AUGER_INA219_H */

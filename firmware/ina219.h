/*
 * INA219 driver: a non-blocking cycle (configuration check, calibration write, bus voltage
 * read, current read)
 * started once per control period and advanced from the main loop over the
 * interrupt-driven TWI master. Every transaction has a timeout.
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
void ina_start_cycle(uint32_t t_ms);
void ina_poll(uint32_t t_ms);
/* A cycle is in progress (a transaction or its timeout to watch). */
bool ina_busy(void);
/* A complete new reading since the last call. */
bool ina_take(ina_reading_t *out);
/* True once each time a cycle fails with INA_FAIL_CYCLES or more failures in a row. */
bool ina_take_failure(void);

#endif /* AUGER_INA219_H */

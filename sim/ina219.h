/*
 * ina219: simavr part, an INA219 on the AVR's TWI bus (slave at addr7, 0x40 on the
 * module). The register semantics live in ina219_regs.c; this part answers the bus
 * (SLA+W pointer [MSB LSB], SLA+R MSB LSB ...), averages the analog inputs over each
 * conversion and completes conversions on a cycle timer at the datasheet's conversion
 * times.
 */
#ifndef AUGER_SIM_INA219_H
#define AUGER_SIM_INA219_H

#include "sim_avr.h"
#include "sim_irq.h"

#include "ina219_regs.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
	IRQ_INA219_TWI_IN = 0, /* messages from the TWI master (TWI_IRQ_OUTPUT) */
	IRQ_INA219_TWI_OUT,    /* replies to the TWI (TWI_IRQ_INPUT) */
	IRQ_INA219_COUNT
};

typedef struct ina219_t {
	avr_irq_t *irq;
	avr_t *avr;
	uint8_t addr7;
	double shunt_ohm;
	ina219_regs_t regs;

	int selected, reading;
	unsigned byte_index;
	uint16_t latch;

	double sum_shunt_v_s, sum_bus_v_s, sum_s;  /* input integrals over the conversion */
	double last_shunt_v, last_bus_v;
	unsigned transactions;                     /* addressed transactions, for tests */
} ina219_t;

void ina219_init(avr_t *avr, ina219_t *p, uint8_t addr7, double shunt_ohm);
/* Wire to the TWI with this ioctl index (0 for the ATmega328P's TWI) and start. */
void ina219_attach(ina219_t *p, uint32_t twi_index);
/* Feed the analog inputs over dt_s: the current through the shunt and the bus voltage. */
void ina219_sample(ina219_t *p, double current_a, double bus_v, double dt_s);
/* Power-on reset, as a supply glitch on a sharp load does to the real chip. */
void ina219_power_on_reset(ina219_t *p);
/* (Re)start conversions for the current mode: after attach and after avr_reset. */
void ina219_start(ina219_t *p);

#ifdef __cplusplus
}
#endif
#endif

/*
 * ina219_regs: the register file of TI's INA219 current/power monitor (datasheet
 * SBOS448, section 8.6), without the bus. sim/ina219.c puts it on simavr's TWI;
 * tests/sim/test_ina219_regs.cpp checks it against the datasheet's examples.
 */
#ifndef AUGER_SIM_INA219_REGS_H
#define AUGER_SIM_INA219_REGS_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

enum {
	INA219_REG_CONFIG = 0x00,
	INA219_REG_SHUNT = 0x01,
	INA219_REG_BUS = 0x02,
	INA219_REG_POWER = 0x03,
	INA219_REG_CURRENT = 0x04,
	INA219_REG_CALIBRATION = 0x05,
	INA219_REG_COUNT
};

#define INA219_CONFIG_RESET_VALUE 0x399Fu
#define INA219_CONFIG_RST 0x8000u
#define INA219_CONFIG_BRNG 0x2000u
#define INA219_BUS_CNVR 0x0002u
#define INA219_BUS_OVF 0x0001u

typedef struct ina219_regs_t {
	uint16_t config;
	uint16_t calibration;
	int16_t shunt;       /* 10 uV LSB */
	uint16_t bus;        /* register as read: value << 3 | CNVR | OVF */
	uint16_t power;
	int16_t current;
	uint8_t pointer;     /* register pointer, set by the first byte of a write */
} ina219_regs_t;

/* Power-on / software reset state. */
void ina219_regs_reset(ina219_regs_t *r);
/* A register write from the bus. Returns 1 when the write changes the operating mode
 * (the caller restarts its conversion timer), else 0. */
int ina219_regs_write(ina219_regs_t *r, uint8_t reg, uint16_t value);
/* A register read from the bus (reading power clears CNVR). Unknown registers read 0. */
uint16_t ina219_regs_read(ina219_regs_t *r, uint8_t reg);
/* A conversion has completed with these averaged inputs: latch shunt, bus, current,
 * power, set CNVR, set or clear OVF. */
void ina219_regs_convert(ina219_regs_t *r, double shunt_v, double bus_v);
/* Operating mode (config bits 2..0): 0 power-down, 1-3 triggered, 4 ADC off,
 * 5-7 continuous. */
unsigned ina219_regs_mode(const ina219_regs_t *r);
/* Time of one complete conversion in the current mode (shunt and/or bus), seconds. */
double ina219_regs_conversion_time_s(const ina219_regs_t *r);
/* Full-scale shunt voltage of the current PGA setting (0.04, 0.08, 0.16, 0.32 V). */
double ina219_regs_shunt_fsr_v(const ina219_regs_t *r);

#ifdef __cplusplus
}
#endif
#endif

/*
 * INA219 register arithmetic (TI datasheet SBOS448, section 8.5), free of hardware so the
 * host tests check it; the TWI driver (ina219.c) moves the bytes.
 */
#ifndef AUGER_INA_MATH_H
#define AUGER_INA_MATH_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define INA_REG_CONFIG 0x00u
#define INA_REG_SHUNT 0x01u
#define INA_REG_BUS 0x02u
#define INA_REG_POWER 0x03u
#define INA_REG_CURRENT 0x04u
#define INA_REG_CAL 0x05u

/* cal = trunc(0.04096 / (current_LSB * R_shunt)); 0 if it does not fit 16 bits. */
uint16_t ina_cal_value(uint32_t current_lsb_ua, uint32_t shunt_mohm);
/* Bus voltage register: bits 15..3 in 4 mV steps; CNVR (bit 1) and OVF (bit 0) dropped. */
uint16_t ina_bus_mv(uint16_t reg);
/* Current register (two's complement) times current_LSB, rounded, clamped to int16 mA. */
int16_t ina_current_ma(uint16_t reg, uint32_t current_lsb_ua);
/* Shunt voltage register (LSB 10 uV) in microvolt. */
int32_t ina_shunt_uv(uint16_t reg);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_INA_MATH_H */

/* INA219 register arithmetic; see ina_math.h. */
#include "ina_math.h"

#include <string.h>

uint16_t ina_cal_value(uint32_t current_lsb_ua, uint32_t shunt_mohm)
{
    /* 0.04096 / (lsb_ua 1e-6 * r_mohm 1e-3) = 40960000 / (lsb_ua * r_mohm) */
    if (current_lsb_ua == 0 || shunt_mohm == 0) return 0;
    uint32_t den = current_lsb_ua * shunt_mohm;
    if (den / shunt_mohm != current_lsb_ua) return 0; /* product overflowed: cal < 1 */
    uint32_t cal = 40960000UL / den;
    return cal > 0xFFFFu ? 0u : (uint16_t)cal;
}

uint16_t ina_bus_mv(uint16_t reg) { return (uint16_t)((reg >> 3) * 4u); }

static int16_t as_i16(uint16_t v)
{
    int16_t r;
    memcpy(&r, &v, sizeof r);
    return r;
}

int16_t ina_current_ma(uint16_t reg, uint32_t current_lsb_ua)
{
    if (current_lsb_ua == 1000u) { /* the default: the register is in mA, skip a division */
        int16_t ma = as_i16(reg);
        return ma == -32768 ? (int16_t)-32767 : ma;
    }
    int32_t ua = (int32_t)as_i16(reg) * (int32_t)current_lsb_ua;
    int32_t ma = ua >= 0 ? (ua + 500) / 1000 : (ua - 500) / 1000;
    if (ma > 32767) return 32767;
    if (ma < -32767) return -32767;
    return (int16_t)ma;
}

int32_t ina_shunt_uv(uint16_t reg) { return (int32_t)as_i16(reg) * 10; }

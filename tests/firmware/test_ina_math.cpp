// INA219 register arithmetic against the TI datasheet (SBOS448) and the build defaults.
#include <catch2/catch.hpp>

#include "config.h"
#include "ina_math.h"

TEST_CASE("ina219: the datasheet's configure/measure/calculate example")
{
    // SBOS448 "Configure/Measure/Calculate Example": 10 A load, 12 V, R_shunt = 2 mOhm,
    // Current_LSB = 1 mA: calibration 5000h = 20480, shunt 07D0h = 20 mV,
    // bus 5D98h = 11.98 V, current 2710h = 10.0 A.
    CHECK(ina_cal_value(1000, 2) == 20480);
    CHECK(ina_shunt_uv(0x07D0) == 20000);
    CHECK(ina_bus_mv(0x5D98) == 11980);
    CHECK(ina_current_ma(0x2710, 1000) == 10000);
    // The chip's own arithmetic: current = shunt * cal / 4096.
    CHECK(0x07D0 * 20480 / 4096 == 0x2710);
}

TEST_CASE("ina219: bus voltage register")
{
    CHECK(ina_bus_mv(uint16_t(8000u << 3)) == 32000); // 32 V full scale = 1F40h << 3
    CHECK(ina_bus_mv(uint16_t((4000u << 3) | 0x3u)) == 16000); // CNVR and OVF ignored
    CHECK(ina_bus_mv(0x0007) == 0);
}

TEST_CASE("ina219: current register is two's complement")
{
    CHECK(ina_current_ma(0xFFFF, 1000) == -1);
    CHECK(ina_current_ma(0x8000, 1000) == -32767); // clamped: -32768 is not symmetric
    CHECK(ina_current_ma(0x7FFF, 1000) == 32767);
    CHECK(ina_current_ma(100, 100) == 10);   // 100 x 100 uA
    CHECK(ina_current_ma(15, 100) == 2);     // 1.5 mA rounds away from zero
    CHECK(ina_current_ma(0xFFF1, 100) == -2);
    CHECK(ina_current_ma(1000, 40000) == 32767); // 40 A does not fit int16 mA
}

TEST_CASE("ina219: calibration formula and the build defaults")
{
    CHECK(ina_cal_value(100, 100) == 4096);  // 0.1 Ohm, 100 uA
    CHECK(ina_cal_value(40, 100) == 10240);
    CHECK(ina_cal_value(1000, 10) == 4096);  // the default 10 mOhm, 1 mA
    CHECK(ina_cal_value(1, 1) == 0);         // 40960000 does not fit 16 bits
    CHECK(ina_cal_value(0, 10) == 0);
    CHECK(ina_cal_value(0xFFFFFFFFu, 0xFFFFFFFFu) == 0);
    CHECK(ina_cal_value(CURRENT_LSB_UA, SHUNT_MOHM) == INA_CAL);
    // Full scale: 320 mV / 10 mOhm = 32 A; the overcurrent limit is well inside.
    CHECK(INA_FULL_SCALE_MA == 32000UL);
    CHECK(OVERCURRENT_MA < INA_FULL_SCALE_MA / 2);
    // Config: 32 V range, PGA /8, 12-bit x8 averaging, continuous shunt and bus.
    CHECK(INA_CONFIG_VALUE == 0x3DDFu);
}

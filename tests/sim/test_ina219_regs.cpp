// The INA219 register file against TI's datasheet (SBOS448): reset values, the
// calibration example of section 8.5, PGA clipping, flags.
#include <catch2/catch.hpp>

#include <cmath>

#include "ina219_regs.h"

TEST_CASE("INA219 resets to the datasheet's values", "[ina219]")
{
	ina219_regs_t r;
	ina219_regs_reset(&r);
	CHECK(ina219_regs_read(&r, INA219_REG_CONFIG) == 0x399F);
	CHECK(ina219_regs_read(&r, INA219_REG_CALIBRATION) == 0);
	CHECK(ina219_regs_mode(&r) == 7);
	CHECK(ina219_regs_shunt_fsr_v(&r) == Approx(0.32));
	// 12-bit shunt and bus, continuous: 532 us each
	CHECK(ina219_regs_conversion_time_s(&r) == Approx(1.064e-3));
	// the reset bit restores everything and clears itself
	ina219_regs_write(&r, INA219_REG_CONFIG, 0x019F);
	ina219_regs_write(&r, INA219_REG_CALIBRATION, 4096);
	ina219_regs_write(&r, INA219_REG_CONFIG, 0x8000);
	CHECK(ina219_regs_read(&r, INA219_REG_CONFIG) == 0x399F);
	CHECK(ina219_regs_read(&r, INA219_REG_CALIBRATION) == 0);
}

TEST_CASE("INA219 calibration example: 32 V, 0.1 ohm, 100 uA current LSB", "[ina219]")
{
	// Section 8.5.1: Cal = trunc(0.04096 / (Current_LSB * R_SHUNT)) = 4096 with a 100 uA
	// current LSB and 0.1 ohm; Power_LSB = 20 * Current_LSB = 2 mW.
	const double r_shunt = 0.1, current_lsb = 100e-6;
	uint16_t cal = (uint16_t)std::trunc(0.04096 / (current_lsb * r_shunt));
	CHECK(cal == 4096);
	ina219_regs_t r;
	ina219_regs_reset(&r);
	ina219_regs_write(&r, INA219_REG_CALIBRATION, cal);
	// 1 A at 12 V: shunt 100 mV
	ina219_regs_convert(&r, 1.0 * r_shunt, 12.0);
	CHECK((int16_t)ina219_regs_read(&r, INA219_REG_SHUNT) == 10000);    // 10 uV LSB
	uint16_t bus = ina219_regs_read(&r, INA219_REG_BUS);
	CHECK((bus >> 3) == 3000);                                          // 4 mV LSB
	CHECK((bus & INA219_BUS_CNVR) != 0);
	CHECK((bus & INA219_BUS_OVF) == 0);
	CHECK((int16_t)ina219_regs_read(&r, INA219_REG_CURRENT) == 10000);  // 1 A / 100 uA
	CHECK(ina219_regs_read(&r, INA219_REG_POWER) == 6000);              // 12 W / 2 mW
	// reading power cleared CNVR
	CHECK((ina219_regs_read(&r, INA219_REG_BUS) & INA219_BUS_CNVR) == 0);
	// negative current: signed shunt and current, power stays positive
	ina219_regs_convert(&r, -0.5 * r_shunt, 12.0);
	CHECK((int16_t)ina219_regs_read(&r, INA219_REG_SHUNT) == -5000);
	CHECK((int16_t)ina219_regs_read(&r, INA219_REG_CURRENT) == -5000);
	CHECK(ina219_regs_read(&r, INA219_REG_POWER) == 3000);
}

TEST_CASE("INA219 current register is shunt * cal / 4096", "[ina219]")
{
	// 32 V / 1 A setting of common drivers: 40 uA LSB, cal 10240 with 0.1 ohm
	ina219_regs_t r;
	ina219_regs_reset(&r);
	ina219_regs_write(&r, INA219_REG_CALIBRATION, 10240);
	ina219_regs_convert(&r, 0.0321, 16.8); // 321 mA
	CHECK((int16_t)ina219_regs_read(&r, INA219_REG_SHUNT) == 3210);
	CHECK((int16_t)ina219_regs_read(&r, INA219_REG_CURRENT) == 3210 * 10240 / 4096);
	CHECK(ina219_regs_read(&r, INA219_REG_POWER) == (3210 * 10240 / 4096) * 4200 / 5000);
	// without calibration the current and power read 0
	ina219_regs_write(&r, INA219_REG_CALIBRATION, 0);
	ina219_regs_convert(&r, 0.0321, 16.8);
	CHECK(ina219_regs_read(&r, INA219_REG_CURRENT) == 0);
	CHECK(ina219_regs_read(&r, INA219_REG_POWER) == 0);
}

TEST_CASE("INA219 clips at the PGA and bus ranges, flags overflow", "[ina219]")
{
	ina219_regs_t r;
	ina219_regs_reset(&r);
	// PGA /1: +-40 mV
	ina219_regs_write(&r, INA219_REG_CONFIG, 0x399F & ~0x1800);
	CHECK(ina219_regs_shunt_fsr_v(&r) == Approx(0.04));
	ina219_regs_convert(&r, 0.1, 12.0);
	CHECK((int16_t)ina219_regs_read(&r, INA219_REG_SHUNT) == 4000);
	ina219_regs_convert(&r, -0.1, 12.0);
	CHECK((int16_t)ina219_regs_read(&r, INA219_REG_SHUNT) == -4000);
	// 16 V range: a 21 V bus reads full scale
	ina219_regs_write(&r, INA219_REG_CONFIG, 0x199F);
	ina219_regs_convert(&r, 0.0, 21.0);
	CHECK((ina219_regs_read(&r, INA219_REG_BUS) >> 3) == 4000);
	// math overflow: 320 mV with a large calibration
	ina219_regs_write(&r, INA219_REG_CONFIG, 0x399F);
	ina219_regs_write(&r, INA219_REG_CALIBRATION, 0xFFFE);
	ina219_regs_convert(&r, 0.32, 20.0);
	CHECK((ina219_regs_read(&r, INA219_REG_BUS) & INA219_BUS_OVF) != 0);
	CHECK((int16_t)ina219_regs_read(&r, INA219_REG_CURRENT) == 32767);
}

TEST_CASE("INA219 register writes: read-only bits and registers", "[ina219]")
{
	ina219_regs_t r;
	ina219_regs_reset(&r);
	ina219_regs_write(&r, INA219_REG_CALIBRATION, 0x1235);
	CHECK(ina219_regs_read(&r, INA219_REG_CALIBRATION) == 0x1234); // bit 0 reads 0
	ina219_regs_write(&r, INA219_REG_SHUNT, 0x1111);
	ina219_regs_write(&r, INA219_REG_CURRENT, 0x1111);
	CHECK(ina219_regs_read(&r, INA219_REG_SHUNT) == 0);
	CHECK(ina219_regs_read(&r, INA219_REG_CURRENT) == 0);
	CHECK(ina219_regs_read(&r, 0x07) == 0);
	// triggered shunt-only mode with 128 samples
	ina219_regs_write(&r, INA219_REG_CONFIG, (0x399F & ~0x7) | 0x1);
	CHECK(ina219_regs_conversion_time_s(&r) == Approx(532e-6));
	ina219_regs_write(&r, INA219_REG_CONFIG, (0x3800 | (0xF << 3) | 0x5));
	CHECK(ina219_regs_conversion_time_s(&r) == Approx(68.10e-3));
}

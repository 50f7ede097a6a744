/* INA219 register semantics, TI SBOS448 sections 8.5-8.6. */
#include "ina219_regs.h"

#include <math.h>
#include <stdlib.h>

void ina219_regs_reset(ina219_regs_t *r)
{
	r->config = INA219_CONFIG_RESET_VALUE;
	r->calibration = 0;
	r->shunt = 0;
	r->bus = 0;
	r->power = 0;
	r->current = 0;
	r->pointer = 0;
}

unsigned ina219_regs_mode(const ina219_regs_t *r)
{
	return r->config & 0x7u;
}

double ina219_regs_shunt_fsr_v(const ina219_regs_t *r)
{
	unsigned pga = (r->config >> 11) & 0x3u;
	return 0.04 * (double)(1u << pga);
}

/* Table 8-7 (ADC settings): 9..12-bit single samples, then 12-bit averaged. */
static double adc_time_s(unsigned code)
{
	static const double averaged_s[8] = {
		532e-6, 1.06e-3, 2.13e-3, 4.26e-3, 8.51e-3, 17.02e-3, 34.05e-3, 68.10e-3
	};
	static const double single_s[4] = { 84e-6, 148e-6, 276e-6, 532e-6 };
	if (code & 0x8u)
		return averaged_s[code & 0x7u];
	return single_s[code & 0x3u];
}

double ina219_regs_conversion_time_s(const ina219_regs_t *r)
{
	unsigned mode = ina219_regs_mode(r);
	double shunt_s = adc_time_s((r->config >> 3) & 0xFu);
	double bus_s = adc_time_s((r->config >> 7) & 0xFu);
	double t = 0;
	if (mode & 0x1u)
		t += shunt_s;
	if (mode & 0x2u)
		t += bus_s;
	return t;
}

int ina219_regs_write(ina219_regs_t *r, uint8_t reg, uint16_t value)
{
	switch (reg) {
	case INA219_REG_CONFIG:
		if (value & INA219_CONFIG_RST) {
			ina219_regs_reset(r);
			return 1;
		}
		r->config = value;
		/* writing a mode clears the conversion-ready flag (8.6.3.1) */
		r->bus &= (uint16_t)~INA219_BUS_CNVR;
		return 1;
	case INA219_REG_CALIBRATION:
		r->calibration = value & 0xFFFEu; /* bit 0 is read-only, always 0 */
		return 0;
	default:
		return 0; /* the data registers are read-only */
	}
}

uint16_t ina219_regs_read(ina219_regs_t *r, uint8_t reg)
{
	switch (reg) {
	case INA219_REG_CONFIG:
		return r->config;
	case INA219_REG_SHUNT:
		return (uint16_t)r->shunt;
	case INA219_REG_BUS:
		return r->bus;
	case INA219_REG_POWER: {
		uint16_t v = r->power;
		r->bus &= (uint16_t)~INA219_BUS_CNVR;
		return v;
	}
	case INA219_REG_CURRENT:
		return (uint16_t)r->current;
	case INA219_REG_CALIBRATION:
		return r->calibration;
	default:
		return 0;
	}
}

void ina219_regs_convert(ina219_regs_t *r, double shunt_v, double bus_v)
{
	unsigned mode = ina219_regs_mode(r);
	int ovf = 0;

	if (mode & 0x1u) {
		/* the PGA clips at its full scale */
		long fs = lround(ina219_regs_shunt_fsr_v(r) / 10e-6);
		long s = lround(shunt_v / 10e-6);
		if (s > fs)
			s = fs;
		if (s < -fs)
			s = -fs;
		r->shunt = (int16_t)s;
	}
	if (mode & 0x2u) {
		/* 4 mV LSB, clipped to the selected range (16 or 32 V) */
		long fs = (r->config & INA219_CONFIG_BRNG) ? 8000 : 4000;
		long b = lround(bus_v / 4e-3);
		if (b < 0)
			b = 0;
		if (b > fs)
			b = fs;
		r->bus = (uint16_t)((b << 3) | (r->bus & INA219_BUS_CNVR));
	}
	/* eq. 4: current = shunt * cal / 4096; eq. 5: power = current * bus / 5000 */
	long current = ((long)r->shunt * (long)r->calibration) / 4096;
	if (current > 32767) {
		current = 32767;
		ovf = 1;
	} else if (current < -32768) {
		current = -32768;
		ovf = 1;
	}
	r->current = (int16_t)current;
	long power = (labs(current) * (long)(r->bus >> 3)) / 5000;
	if (power > 65535) {
		power = 65535;
		ovf = 1;
	}
	r->power = (uint16_t)power;
	r->bus = (uint16_t)((r->bus & ~(INA219_BUS_OVF)) | INA219_BUS_CNVR | (ovf ? INA219_BUS_OVF : 0));
}

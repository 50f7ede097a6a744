/* Li-ion pack: OCV table per cell, series resistance, coulomb counting. */
#include "battery.h"

/* Typical NMC 18650 rest voltage every 10 % of charge, 3.0 V empty to 4.2 V full
 * (docs/simulator.md: a generic curve, not one cell's datasheet). */
static const double ocv_table_v[11] = {
	3.00, 3.45, 3.55, 3.62, 3.68, 3.74, 3.82, 3.90, 3.98, 4.08, 4.20
};

void battery_params_default(battery_params_t *p)
{
	p->cells_series = 5;
	p->capacity_ah = 2.5;
	p->r_cell_ohm = 0.05;
	p->r_wiring_ohm = 0.05;
	p->soc_initial = 0.8;
}

void battery_init(battery_t *b, const battery_params_t *p)
{
	b->p = *p;
	b->soc = p->soc_initial;
	b->forced_v = 0;
	b->drawn_c = 0;
}

double battery_cell_ocv_v(double soc)
{
	if (soc <= 0)
		return ocv_table_v[0];
	if (soc >= 1)
		return ocv_table_v[10];
	double x = soc * 10.0;
	int i = (int)x;
	double f = x - i;
	return ocv_table_v[i] + f * (ocv_table_v[i + 1] - ocv_table_v[i]);
}

double battery_ocv_v(const battery_t *b)
{
	if (b->forced_v > 0)
		return b->forced_v;
	return b->p.cells_series * battery_cell_ocv_v(b->soc);
}

double battery_terminal_v(const battery_t *b, double current_a)
{
	if (b->forced_v > 0)
		return b->forced_v;
	double r = b->p.cells_series * b->p.r_cell_ohm + b->p.r_wiring_ohm;
	double v = battery_ocv_v(b) - r * current_a;
	return v > 0 ? v : 0;
}

void battery_draw(battery_t *b, double current_a, double dt_s)
{
	b->drawn_c += current_a * dt_s;
	b->soc -= current_a * dt_s / (3600.0 * b->p.capacity_ah);
	if (b->soc < 0)
		b->soc = 0;
	if (b->soc > 1)
		b->soc = 1;
}

void battery_force_v(battery_t *b, double v)
{
	b->forced_v = v > 0 ? v : 0;
}

void battery_set_soc(battery_t *b, double soc)
{
	b->soc = soc < 0 ? 0 : soc > 1 ? 1 : soc;
}

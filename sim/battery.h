/*
 * battery: the module's pack of Li-ion cells in series (five 18650 cells, 15-21 V), open
 * circuit voltage from the state of charge, internal resistance, charge drawn by the
 * motor. No simavr dependency. Used by sim/simmod.c; tests/sim/test_battery.cpp.
 */
#ifndef AUGER_SIM_BATTERY_H
#define AUGER_SIM_BATTERY_H

#ifdef __cplusplus
extern "C" {
#endif

typedef struct battery_params_t {
	int cells_series;        /* 5 */
	double capacity_ah;      /* per cell (the string's capacity): 2.5 Ah */
	double r_cell_ohm;       /* internal resistance per cell: 0.05 ohm */
	double r_wiring_ohm;     /* wiring, connectors, fuse: 0.05 ohm */
	double soc_initial;      /* 0..1 */
} battery_params_t;

typedef struct battery_t {
	battery_params_t p;
	double soc;          /* state of charge 0..1 */
	double drawn_c;      /* charge delivered since creation, coulombs (exact pack current
	                      * integral: tests average the current over a window with it) */
	double forced_v;     /* > 0: terminal voltage forced (tests), model ignored */
} battery_t;

void battery_params_default(battery_params_t *p);
void battery_init(battery_t *b, const battery_params_t *p);
/* Open-circuit voltage of one cell at a state of charge (0..1, clamped). */
double battery_cell_ocv_v(double soc);
double battery_ocv_v(const battery_t *b);
/* Terminal voltage while current_a flows out of the pack (negative: charging). */
double battery_terminal_v(const battery_t *b, double current_a);
/* Take current_a out of the pack for dt_s. */
void battery_draw(battery_t *b, double current_a, double dt_s);
/* Force the terminal voltage (tests: 15 V, 21 V, under-voltage); v <= 0 releases it. */
void battery_force_v(battery_t *b, double v);
void battery_set_soc(battery_t *b, double soc);

#ifdef __cplusplus
}
#endif
#endif

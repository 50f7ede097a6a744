// The five-cell pack model.
#include <catch2/catch.hpp>

#include "battery.h"

TEST_CASE("battery spans 15-21 V over its charge", "[battery]")
{
	battery_params_t p;
	battery_params_default(&p);
	battery_t b;
	battery_init(&b, &p);
	battery_set_soc(&b, 0.0);
	CHECK(battery_ocv_v(&b) == Approx(15.0));
	battery_set_soc(&b, 1.0);
	CHECK(battery_ocv_v(&b) == Approx(21.0));
	// monotonic
	double prev = 0;
	for (int i = 0; i <= 100; i++) {
		double v = battery_cell_ocv_v(i / 100.0);
		CHECK(v >= prev);
		prev = v;
	}
}

TEST_CASE("battery sags with current and discharges by coulomb counting", "[battery]")
{
	battery_params_t p;
	battery_params_default(&p);
	battery_t b;
	battery_init(&b, &p);
	double ocv = battery_ocv_v(&b);
	CHECK(battery_terminal_v(&b, 10.0) == Approx(ocv - 10.0 * 0.3));
	double soc = b.soc;
	battery_draw(&b, 0.5, 3600.0); // a fifth of the capacity
	CHECK(b.soc == Approx(soc - 0.2).margin(1e-12));
	battery_draw(&b, 2.5, 3600.0); // more than is left
	CHECK(b.soc == 0.0);
	battery_draw(&b, -0.25, 3600.0); // charging
	CHECK(b.soc == Approx(0.1));
}

TEST_CASE("battery voltage can be forced and released", "[battery]")
{
	battery_params_t p;
	battery_params_default(&p);
	battery_t b;
	battery_init(&b, &p);
	battery_force_v(&b, 15.5);
	CHECK(battery_terminal_v(&b, 20.0) == 15.5);
	battery_force_v(&b, 0);
	CHECK(battery_terminal_v(&b, 0.0) == Approx(battery_ocv_v(&b)));
}

// The motor + gearbox + screw model alone: its datasheet points and its limits.
#include <catch2/catch.hpp>

#include <cmath>

#include "motor_model.h"

namespace {

// Run at a constant terminal voltage until steady.
double settle_rpm(motor_model_t &m, double v, double t_s)
{
	for (double t = 0; t < t_s; t += 1e-4)
		motor_model_step(&m, v, 1e-4);
	return motor_model_out_rpm(&m);
}

} // namespace

TEST_CASE("motor params derive the datasheet points", "[motor]")
{
	motor_params_t p;
	motor_params_default(&p);
	CHECK(p.resistance_ohm == Approx(12.0 / 20.0));
	CHECK(p.ke_v_s_per_rad > 0);
	// no load: V = R I0 + ke w0
	double w0 = 23.0 * 369.0 * 2 * M_PI / 60.0;
	CHECK(p.resistance_ohm * p.no_load_current_a + p.ke_v_s_per_rad * w0 == Approx(12.0));
}

TEST_CASE("motor reaches 23 rpm with no load at 12 V, both ways", "[motor]")
{
	motor_params_t p;
	motor_params_default(&p);
	motor_model_t m;
	motor_model_init(&m, &p);
	CHECK(settle_rpm(m, 12.0, 1.0) == Approx(23.0).epsilon(0.005));
	CHECK(m.current_a == Approx(0.52).epsilon(0.01));
	CHECK(settle_rpm(m, -12.0, 1.5) == Approx(-23.0).epsilon(0.005));
	// about 1 rpm per 0.52 V
	CHECK(settle_rpm(m, 6.0, 1.5) == Approx(11.5).margin(0.5));
}

TEST_CASE("motor speed falls linearly with load and stalls at the stall torque", "[motor]")
{
	motor_params_t p;
	motor_params_default(&p);
	double stall_nm = motor_model_stall_out_nm(&p, 12.0);
	CHECK(stall_nm > 30.0); // 0.26 N m x 369 x 0.7
	motor_model_t m;
	motor_model_init(&m, &p);
	m.load_nm = 0.5 * stall_nm;
	double half = settle_rpm(m, 12.0, 1.0);
	CHECK(half == Approx(0.5 * 23.0).margin(1.0));
	CHECK(m.current_a == Approx(10.0).margin(0.6));
	motor_model_init(&m, &p);
	m.load_nm = stall_nm;
	CHECK(std::fabs(settle_rpm(m, 12.0, 1.0)) < 0.05);
	CHECK(m.current_a == Approx(20.0).margin(0.1));
	// more than the stall torque back-drives it
	m.load_nm = 1.5 * stall_nm;
	CHECK(settle_rpm(m, 12.0, 1.0) < -1.0);
}

TEST_CASE("motor brakes to rest at 0 V and stays there", "[motor]")
{
	for (double l_h : {0.0, 0.5e-3}) {
		INFO("inductance " << l_h << " H");
		motor_params_t p;
		motor_params_default(&p);
		p.inductance_h = l_h;
		motor_model_t m;
		motor_model_init(&m, &p);
		settle_rpm(m, 12.0, 1.0);
		// braking: shorted terminals, current driven by the back-EMF alone, opposing
		// motion; with inductance it builds up over L/R = 0.8 ms
		for (int i = 0; i < 30; ++i)
			motor_model_step(&m, 0.0, 1e-4);
		CHECK(m.current_a < -10.0);
		CHECK(settle_rpm(m, 0.0, 0.3) == 0.0);
		CHECK(std::fabs(m.current_a) < 1e-6);
	}
}

TEST_CASE("motor with inductance agrees with the quasi-static model in steady state", "[motor]")
{
	motor_params_t p;
	motor_params_default(&p);
	p.inductance_h = 0.5e-3;
	motor_model_t m;
	motor_model_init(&m, &p);
	CHECK(settle_rpm(m, 12.0, 1.0) == Approx(23.0).epsilon(0.005));
	CHECK(m.current_a == Approx(0.52).epsilon(0.01));
}

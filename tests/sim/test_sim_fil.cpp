// The simulator's parts under simavr, driven by the fixture firmwares of fixtures/:
// UART both ways (callback and pty), PWM duty and DIR from the pins, the motor, the
// encoder edges against a firmware decoder, the INA219 over TWI, stack painting.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "sim_avr.h"
#include "sim_io.h"
#include "encoder_rate.h"
#include "simmod.h"

namespace {

const std::string fx_echo = std::string(FX_DIR) + "/fx_echo.elf";
const std::string fx_board = std::string(FX_DIR) + "/fx_board.elf";
const char *const optiboot_hex =
	"/usr/share/arduino/hardware/arduino/avr/bootloaders/optiboot/optiboot_atmega328.hex";
const char *const avrdude = "/usr/bin/avrdude";

struct Rx {
	std::vector<std::vector<uint8_t>> bytes = std::vector<std::vector<uint8_t>>(SIMMOD_MAX_MODULES);
	std::vector<double> last_t_s = std::vector<double>(SIMMOD_MAX_MODULES, 0.0);
};

void on_byte(void *ctx, int module, uint8_t byte, double t_s)
{
	Rx *rx = static_cast<Rx *>(ctx);
	rx->bytes[module].push_back(byte);
	rx->last_t_s[module] = t_s;
}

struct Bench {
	simmod_t *sim = nullptr;
	Rx rx;
	explicit Bench(const std::string &elf, int count = 1, int threads = 1, const char *pty_dir = nullptr,
			int exact_pwm = 0)
	{
		simmod_config_t cfg;
		simmod_config_default(&cfg);
		cfg.elf_path = elf.c_str();
		cfg.count = count;
		cfg.threads = threads;
		cfg.pty_dir = pty_dir;
		cfg.exact_pwm = exact_pwm;
		sim = simmod_create(&cfg);
		REQUIRE(sim != nullptr);
		simmod_set_uart_callback(sim, on_byte, &rx);
	}
	~Bench() { simmod_destroy(sim); }
	Bench(const Bench &) = delete;
	Bench &operator=(const Bench &) = delete;

	void run(double dt_s) { simmod_step_to(sim, simmod_time_s(sim) + dt_s); }

	// Step 1 ms at a time until module m has sent n bytes in all; false on timeout.
	bool wait_bytes(int m, size_t n, double timeout_s = 0.5)
	{
		double end = simmod_time_s(sim) + timeout_s;
		while (rx.bytes[m].size() < n && simmod_time_s(sim) < end)
			run(1e-3);
		return rx.bytes[m].size() >= n;
	}

	// Send a command, wait for reply_len bytes, return them.
	std::vector<uint8_t> cmd(int m, std::vector<uint8_t> out, size_t reply_len)
	{
		rx.bytes[m].clear();
		simmod_uart_send(sim, m, out.data(), out.size());
		REQUIRE(wait_bytes(m, reply_len));
		return rx.bytes[m];
	}

	void boot(int m = 0)
	{
		REQUIRE(wait_bytes(m, 1));
		REQUIRE(rx.bytes[m][0] == '!');
		rx.bytes[m].clear();
	}
};

void set_pwm(Bench &b, uint16_t ocr, bool dir)
{
	auto r = b.cmd(0, { 'P', (uint8_t)(ocr & 0xFF), (uint8_t)(ocr >> 8), (uint8_t)dir }, 1);
	REQUIRE(r[0] == 'p');
}

int32_t firmware_count(Bench &b, uint16_t *errors)
{
	auto r = b.cmd(0, { 'E' }, 7);
	REQUIRE(r[0] == 'e');
	*errors = (uint16_t)(r[5] | (r[6] << 8));
	return (int32_t)((uint32_t)r[1] | ((uint32_t)r[2] << 8) | ((uint32_t)r[3] << 16) | ((uint32_t)r[4] << 24));
}

uint16_t ina_read(Bench &b, uint8_t reg)
{
	auto r = b.cmd(0, { 'R', reg }, 4);
	REQUIRE(r[0] == 'r');
	REQUIRE(r[3] == 0);
	return (uint16_t)((r[1] << 8) | r[2]);
}

void ina_write(Bench &b, uint8_t reg, uint16_t v)
{
	auto r = b.cmd(0, { 'W', reg, (uint8_t)(v >> 8), (uint8_t)v }, 2);
	REQUIRE(r[0] == 'w');
	REQUIRE(r[1] == 0);
}

} // namespace

TEST_CASE("UART bytes pass both ways, more than simavr's 63-byte FIFO at once", "[fil][uart]")
{
	Bench b(fx_echo);
	b.boot();
	std::vector<uint8_t> out(500);
	for (size_t i = 0; i < out.size(); i++)
		out[i] = (uint8_t)(i * 7 + 3);
	simmod_uart_send(b.sim, 0, out.data(), out.size());
	// 500 bytes at 250000 baud (simavr: 11 bits a byte) take 22 ms
	REQUIRE(b.wait_bytes(0, out.size(), 0.1));
	CHECK(b.rx.bytes[0] == out);
	CHECK(b.rx.last_t_s[0] == Approx(0.022).margin(0.003));
}

TEST_CASE("PWM duty and DIR are read from the pins", "[fil][motor]")
{
	Bench b(fx_board);
	b.boot();
	for (uint16_t ocr : { 1, 80, 400, 555, 798, 2 }) {
		set_pwm(b, ocr, ocr % 2);
		b.run(5e-3);
		INFO("OCR1A " << ocr);
		// one count of TOP + 1 = 800
		// fast PWM holds the pin high for OCR1A + 1 of TOP + 1 = 800 counts: within one count
		CHECK(simmod_pwm_duty(b.sim, 0) == Approx((ocr + 1) / 800.0).margin(1.0 / 800));
		CHECK(simmod_dir_pin(b.sim, 0) == ocr % 2);
	}
	// OCR1A = 0: the chip gives a one-count spike each period; simavr 1.6 a few cycles
	set_pwm(b, 0, 1);
	b.run(5e-3);
	CHECK(simmod_pwm_duty(b.sim, 0) < 0.005);
}

TEST_CASE("Timer1's PWM from its registers drives the motor as simavr's stepped timer does", "[fil][motor]")
{
	// The same duties through sim/pwm_model.c and through simavr's Timer1 (exact_pwm): the
	// motor's speed, the pack's charge and the PWM readings agree; the model skips the 32 000
	// timer events a second that the stepped timer costs.
	Bench model(fx_board), exact(fx_board, 1, 1, nullptr, 1);
	model.boot();
	exact.boot();
	for (uint16_t ocr : { 600, 200, 798, 0, 450 }) {
		for (Bench *b : { &model, &exact }) {
			set_pwm(*b, ocr, ocr != 200);
			b->run(0.2);
		}
		INFO("OCR1A " << ocr);
		// simavr moves the pin when it processes its timers, up to an instruction late
		CHECK(simmod_shaft_speed_rpm(model.sim, 0) ==
				Approx(simmod_shaft_speed_rpm(exact.sim, 0)).epsilon(0.003).margin(0.01));
		CHECK(simmod_battery_charge_c(model.sim, 0) ==
				Approx(simmod_battery_charge_c(exact.sim, 0)).epsilon(0.002).margin(1e-4));
		CHECK(simmod_pwm_duty(model.sim, 0) == Approx(simmod_pwm_duty(exact.sim, 0)).margin(1.0 / 800));
		CHECK(simmod_pwm_quiet_s(model.sim, 0) < 1.0 / 20000);  // edges every period
	}
	// OCR1A = TOP: the datasheet's constant high (ATmega328P, 15.9.3); simavr 1.6's stepped
	// timer gives constant low there (the firmware never asks it: its duty cap is below 1 above
	// a 12 V battery).
	set_pwm(model, 799, 1);
	model.run(0.01);
	CHECK(simmod_pwm_duty(model.sim, 0) == 1.0);
	// Timer1 used beyond PWM on OC1A (here its counter read, as a firmware's `in` of TCNT1L
	// does): the model hands it back to simavr, which goes on with the pin.
	auto *avr = static_cast<avr_t *>(simmod_avr(model.sim, 0));
	const avr_io_addr_t tcnt1l = 0x84;
	avr->io[AVR_DATA_TO_IO(tcnt1l)].r.c(avr, tcnt1l, avr->io[AVR_DATA_TO_IO(tcnt1l)].r.param);
	set_pwm(model, 300, 1);
	model.run(0.05);
	CHECK(simmod_pwm_duty(model.sim, 0) == Approx(301 / 800.0).margin(1.0 / 800));
}

TEST_CASE("instruction runs until the next timer give the same simulation as one at a time", "[fil]")
{
	// simmod lets simavr run instructions until the next cycle timer (run_cycle_limit); a
	// step hook makes it go one at a time. Same firmware, same inputs: same bytes at the
	// same times, same cycles, same shaft.
	struct Run {
		std::vector<int64_t> answers; /* encoder counts and errors, INA219 bus readings */
		std::vector<double> answer_t_s;
		uint64_t cycles, sleep;
		double angle_rad;
	};
	auto run = [](bool one_at_a_time) {
		Bench b(fx_board);
		if (one_at_a_time)
			simmod_set_step_hook(b.sim, 0, [](void *, int, const simmod_step_info_t *) {}, nullptr);
		b.boot();
		Run r;
		for (uint16_t ocr : { 600, 200, 0, 700 }) {
			set_pwm(b, ocr, ocr != 200);
			b.run(0.1);
			uint16_t errors = 0;
			r.answers.push_back(firmware_count(b, &errors));
			r.answers.push_back(errors);
			r.answer_t_s.push_back(b.rx.last_t_s[0]);
			r.answers.push_back(ina_read(b, 0x02));
			r.answer_t_s.push_back(b.rx.last_t_s[0]);
		}
		r.cycles = simmod_cycles(b.sim, 0);
		r.sleep = simmod_sleep_cycles(b.sim, 0);
		r.angle_rad = simmod_motor_angle_rad(b.sim, 0);
		return r;
	};
	const Run batched = run(false), single = run(true);
	CHECK(batched.answers == single.answers);
	CHECK(batched.answer_t_s == single.answer_t_s);
	CHECK(batched.cycles == single.cycles);
	CHECK(batched.sleep == single.sleep);
	CHECK(batched.angle_rad == single.angle_rad);
}

TEST_CASE("motor reaches 23 rpm no-load at 12 V and stalls under its stall load", "[fil][motor]")
{
	Bench b(fx_board);
	b.boot();
	simmod_set_battery_voltage(b.sim, 0, 16.0);
	set_pwm(b, 600, 1); // 75 % of 16 V = 12 V
	b.run(1.0);
	CHECK(simmod_shaft_speed_rpm(b.sim, 0) == Approx(23.0).epsilon(0.02));
	set_pwm(b, 600, 0);
	b.run(1.0);
	CHECK(simmod_shaft_speed_rpm(b.sim, 0) == Approx(-23.0).epsilon(0.02));
	motor_params_t p;
	motor_params_default(&p);
	simmod_set_load_torque(b.sim, 0, -motor_model_stall_out_nm(&p, 12.0)); // opposes negative rotation
	b.run(1.0);
	CHECK(std::fabs(simmod_shaft_speed_rpm(b.sim, 0)) < 0.2);
	CHECK(std::fabs(simmod_motor_current_a(b.sim, 0)) == Approx(20.0).epsilon(0.05));
	// duty 0 brakes
	simmod_set_load_torque(b.sim, 0, 0);
	set_pwm(b, 600, 1);
	b.run(0.5);
	set_pwm(b, 0, 1);
	b.run(0.3);
	CHECK(simmod_shaft_speed_rpm(b.sim, 0) == 0.0);
}

TEST_CASE("encoder count equals the true count at top speed and through reversals", "[fil][encoder]")
{
	Bench b(fx_board);
	b.boot();
	simmod_set_battery_voltage(b.sim, 0, 21.0);
	uint16_t errors = 0;
	CHECK(firmware_count(b, &errors) == 0);
	int64_t before = 0;
	for (int k = 0; k < 6; k++) {
		// 799/800 of 21 V: about 40 rpm out, 13k edges/s (OCR1A = TOP would hold PB1 low
		// in simavr 1.6, not high as on the chip)
		set_pwm(b, 798, k % 2 == 0);
		b.run(0.3);
		CHECK(std::fabs(simmod_shaft_speed_rpm(b.sim, 0)) > 35.0);
		set_pwm(b, 0, k % 2 == 0); // brake to rest, then compare
		b.run(0.1);
		REQUIRE(simmod_shaft_speed_rpm(b.sim, 0) == 0.0);
		int32_t fw = firmware_count(b, &errors);
		INFO("reversal " << k);
		CHECK(fw == (int32_t)simmod_encoder_count(b.sim, 0));
		CHECK(errors == 0);
		int64_t now = simmod_encoder_count(b.sim, 0);
		CHECK(std::abs(now - before) > 3000); // it did turn, about 3600 counts a leg
		before = now;
	}
	// and the count matches the shaft angle: 48 counts per motor turn
	double counts = simmod_motor_angle_rad(b.sim, 0) / (2 * M_PI) * 48;
	CHECK(std::fabs(counts - (double)simmod_encoder_count(b.sim, 0)) <= 1.0);
}

TEST_CASE("forced encoder rate: edges at the imposed rate, then back to the shaft without a jump", "[fil][encoder]")
{
	Bench b(fx_board);
	b.boot();
	uint16_t errors = 0;
	// 40 000 edges/s downwards, jittered +-50 %: 4000 counts in 0.1 s (+-1 for the phase)
	int64_t c0 = simmod_encoder_count(b.sim, 0);
	encoder_rate_force(b.sim, 0, -40000.0, 0.5, 42);
	b.run(0.1);
	int64_t c1 = simmod_encoder_count(b.sim, 0);
	CHECK(std::llabs((c0 - c1) - 4000) <= 40); // the mean of 4000 jittered intervals
	CHECK(simmod_shaft_speed_rpm(b.sim, 0) == 0.0); // the motor model is not involved
	encoder_rate_force(b.sim, 0, 0.0, 0.0, 0); // back to the shaft, which is at rest
	b.run(0.01);
	CHECK(simmod_encoder_count(b.sim, 0) == c1);
	CHECK(firmware_count(b, &errors) == (int32_t)c1); // the fixture's decoder saw every edge
	CHECK(errors == 0);
	// the shaft moves again: the count follows it from where the forced run left it
	set_pwm(b, 400, true);
	b.run(0.2);
	set_pwm(b, 0, true);
	b.run(0.1);
	int64_t c2 = simmod_encoder_count(b.sim, 0);
	CHECK(c2 > c1 + 100);
	CHECK(firmware_count(b, &errors) == (int32_t)c2);
	CHECK(errors == 0);
}

TEST_CASE("sleep cycles are counted and never exceed the cycles run", "[fil]")
{
	Bench b(fx_echo);
	b.boot();
	uint64_t c0 = simmod_cycles(b.sim, 0), s0 = simmod_sleep_cycles(b.sim, 0);
	b.run(0.05);
	uint64_t dc = simmod_cycles(b.sim, 0) - c0, ds = simmod_sleep_cycles(b.sim, 0) - s0;
	CHECK(ds > 0);
	CHECK(ds <= dc);
}

TEST_CASE("INA219 over TWI reads the simulated current and voltage within resolution", "[fil][ina219]")
{
	Bench b(fx_board);
	b.boot();
	CHECK(ina_read(b, 0x00) == 0x399F);
	// 0.01 ohm shunt, 1 mA LSB: cal = 0.04096 / (0.001 * 0.01) = 4096
	ina_write(b, 0x05, 4096);
	CHECK(ina_read(b, 0x05) == 4096);
	simmod_set_battery_voltage(b.sim, 0, 18.0);
	simmod_set_load_torque(b.sim, 0, 20.0);
	set_pwm(b, 400, 1);
	b.run(1.0);
	double i_a = simmod_battery_current_a(b.sim, 0);
	REQUIRE(i_a > 1.0);
	double bus_v = (ina_read(b, 0x02) >> 3) * 4e-3;
	int16_t shunt = (int16_t)ina_read(b, 0x01);
	int16_t current = (int16_t)ina_read(b, 0x04);
	CHECK(bus_v == Approx(18.0 - i_a * 0.01).margin(0.004 + 1e-3));
	CHECK(shunt * 10e-6 / 0.01 == Approx(i_a).margin(0.001 + 0.01 * i_a));
	CHECK(current * 1e-3 == Approx(i_a).margin(0.002 + 0.01 * i_a));
	// a supply glitch resets the chip: calibration lost, current reads 0
	simmod_ina219_glitch(b.sim, 0);
	b.run(5e-3);
	CHECK(ina_read(b, 0x05) == 0);
	CHECK(ina_read(b, 0x04) == 0);
}

TEST_CASE("stack painting read-back reports the headroom", "[fil][stack]")
{
	Bench b(fx_board);
	b.boot();
	int before = simmod_stack_headroom(b.sim, 0, 0xC5);
	CHECK(before > 1500);
	auto r = b.cmd(0, { 'D', 20 }, 1);
	CHECK(r[0] == 'd');
	int after = simmod_stack_headroom(b.sim, 0, 0xC5);
	CHECK(after < before - 20 * 16);
	CHECK(after > 1000);
}

TEST_CASE("pty bridge passes bytes both ways", "[fil][pty]")
{
	char dir[] = "/tmp/auger-sim-test-XXXXXX";
	REQUIRE(mkdtemp(dir) != nullptr);
	{
		Bench b(fx_echo, 1, 1, dir);
		std::string link = simmod_pty_link(b.sim, 0);
		CHECK(link == std::string(dir) + "/module0");
		b.run(0.01);
		int fd = open(link.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
		REQUIRE(fd >= 0);
		struct termios t;
		tcgetattr(fd, &t);
		cfmakeraw(&t);
		tcsetattr(fd, TCSANOW, &t);
		b.run(0.01);
		const char msg[] = "hello\x00\xff\r\n";
		REQUIRE(write(fd, msg, sizeof(msg) - 1) == (ssize_t)(sizeof(msg) - 1));
		b.run(0.01);
		std::string got;
		char buf[64];
		for (int i = 0; i < 50 && got.size() < sizeof(msg) - 1; i++) {
			b.run(1e-3);
			ssize_t n = read(fd, buf, sizeof(buf));
			if (n > 0)
				got.append(buf, (size_t)n);
		}
		CHECK(got == std::string(msg, sizeof(msg) - 1));
		close(fd);
	}
	CHECK(access((std::string(dir) + "/module0").c_str(), F_OK) != 0); // link removed
	rmdir(dir);
}

TEST_CASE("four modules run on threads and alone alike", "[fil][multi]")
{
	for (int threads : { 1, 2 }) {
		Bench b(fx_board, 4, threads);
		for (int m = 0; m < 4; m++)
			REQUIRE(b.wait_bytes(m, 1));
		for (int m = 0; m < 4; m++) {
			uint16_t ocr = (uint16_t)(200 * m);
			uint8_t cmd[4] = { 'P', (uint8_t)(ocr & 0xFF), (uint8_t)(ocr >> 8), 1 };
			simmod_uart_send(b.sim, m, cmd, 4);
		}
		auto t0 = std::chrono::steady_clock::now();
		b.run(2.0);
		double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
		WARN("4 modules, " << threads << " thread(s): " << 2.0 / wall << "x real time");
		for (int m = 0; m < 4; m++)
			CHECK(simmod_pwm_duty(b.sim, m) == Approx((200 * m + 1) / 800.0).margin(1.0 / 800));
	}
}

TEST_CASE("a clock offset makes a module's crystal run fast or slow", "[fil][clock]")
{
	simmod_config_t cfg;
	simmod_config_default(&cfg);
	cfg.elf_path = fx_echo.c_str();
	cfg.count = 2;
	cfg.clock_offset_ppm[0] = 5000;
	cfg.clock_offset_ppm[1] = -5000;
	simmod_t *sim = simmod_create(&cfg);
	REQUIRE(sim != nullptr);
	simmod_step_to(sim, 1.0);
	CHECK((double)simmod_cycles(sim, 0) == Approx(16.08e6).margin(1000));
	CHECK((double)simmod_cycles(sim, 1) == Approx(15.92e6).margin(1000));
	simmod_destroy(sim);
}

TEST_CASE("the real avrdude flashes through Optiboot over the pty, and the image runs", "[fil][flash]")
{
	// Both come from scripts/install-deps.sh (arduino-core-avr, avrdude): a missing one is a
	// broken installation, not a reason to skip.
	REQUIRE(access(optiboot_hex, R_OK) == 0);
	REQUIRE(access(avrdude, X_OK) == 0);
	char dir[] = "/tmp/auger-sim-flash-XXXXXX";
	REQUIRE(mkdtemp(dir) != nullptr);
	simmod_config_t cfg;
	simmod_config_default(&cfg);
	cfg.elf_path = fx_board.c_str(); // the old image; avrdude replaces it with fx_echo
	cfg.pty_dir = dir;
	cfg.realtime = 1; // avrdude's timeouts are wall-clock
	cfg.reset_on_open = 1;
	cfg.bootloader_hex = optiboot_hex;
	simmod_t *sim = simmod_create(&cfg);
	REQUIRE(sim != nullptr);
	std::string port = simmod_pty_link(sim, 0);
	std::string image = "flash:w:" + std::string(FX_DIR) + "/fx_echo.hex:i";
	const char *argv[] = { "avrdude", "-q", "-q", "-c", "arduino", "-p", "m328p", "-P", port.c_str(),
		"-b", "115200", "-U", image.c_str(), nullptr };
	pid_t pid;
	REQUIRE(posix_spawn(&pid, avrdude, nullptr, nullptr, const_cast<char **>(argv), environ) == 0);
	int status = 0;
	double t = 0;
	while (waitpid(pid, &status, WNOHANG) == 0 && t < 30.0) {
		t += 0.01;
		simmod_step_to(sim, t);
	}
	REQUIRE(WIFEXITED(status));
	CHECK(WEXITSTATUS(status) == 0);

	// open the port as a host would: reset, Optiboot waits ~1 s, then starts fx_echo
	int fd = open(port.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
	REQUIRE(fd >= 0);
	struct termios tio;
	tcgetattr(fd, &tio);
	cfmakeraw(&tio);
	tcsetattr(fd, TCSANOW, &tio);
	simmod_step_to(sim, t += 1.5);
	REQUIRE(write(fd, "ok?", 3) == 3);
	std::string got;
	char buf[64];
	for (int i = 0; i < 50 && got.size() < 4; i++) {
		simmod_step_to(sim, t += 0.01);
		ssize_t n = read(fd, buf, sizeof(buf));
		if (n > 0)
			got.append(buf, (size_t)n);
	}
	CHECK(got == "!ok?"); // fx_echo's greeting, once (no watchdog reset loop), then the echo
	close(fd);
	simmod_destroy(sim);
	rmdir(dir);
}

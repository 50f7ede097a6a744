/*
 * simmod: the board. Builds one simavr ATmega328P per module from the firmware ELF, wires
 * the parts to docs/hardware.md's pins, handles resets, and answers simmod.h's accessors.
 * Loading: simmod_load.c; the UART pump: simmod_uart.c; running the modules in simulated
 * time (threads, pacing): simmod_run.c.
 */
#define _DEFAULT_SOURCE
#include "simmod_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "avr_eeprom.h"
#include "avr_extint.h"
#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_elf.h"

/* ---- logging: simavr's messages go to stderr, filtered ---- */

static int log_level = LOG_ERROR;

static void sim_logger(avr_t *avr, const int level, const char *format, va_list ap)
{
	(void)avr;
	if (level <= log_level)
		vfprintf(stderr, format, ap);
}

/* Replaces simavr's pacing sleep (batch runs do not sleep; real-time runs are paced by
 * simmod_step_to) and counts the cycles the AVR slept: simavr 1.6 advances the cycle
 * counter by 1 + how_long after this call (sim_avr.c, avr_callback_run_raw). */
static void sleep_count(avr_t *avr, avr_cycle_count_t how_long)
{
	module_t *m = (module_t *)avr->custom.data;
	m->sleep_cycles += 1 + how_long;
}










/* ---- the parts' glue ---- */

static void motor_step_to_parts(void *ctx, avr_cycle_count_t from, avr_cycle_count_t to,
		double angle_from_rad, double angle_to_rad, double battery_current_a,
		double battery_v, double dt_s)
{
	module_t *m = (module_t *)ctx;
	encoder_move(&m->encoder, from, to, angle_from_rad, angle_to_rad);
	/* high-side shunt on the battery line: the bus voltage is measured after it */
	ina219_sample(&m->ina, battery_current_a,
			battery_v - battery_current_a * m->ina.shunt_ohm, dt_s);
}

/* After every reset of the AVR, whoever caused it: simavr has cleared every cycle timer
 * and the data space. */
static void extint_fix(avr_t *avr)
{
	/* without this, a low PD2/PD3 makes simavr poll INT0/INT1 every cycle, masked or
	 * not (docs/simulator.md): 5-100x slower */
	avr_extint_set_strict_lvl_trig(avr, 0, 0);
	avr_extint_set_strict_lvl_trig(avr, 1, 0);
}

/* One cycle after a reset, once every peripheral has reset: only then drive the encoder
 * pins again (a low level seen while INT0/INT1 are still strict starts the polling). */
static avr_cycle_count_t board_after_reset_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)when;
	module_t *m = (module_t *)param;
	extint_fix(avr);
	encoder_restart(&m->encoder, m->motor.model.angle_rad);
	return 0;
}

static void board_reset_hook(struct avr_io_t *io)
{
	module_t *m = (module_t *)((char *)io - offsetof(module_t, board_io));
	m->reset_seen = 1;
	motor_start(&m->motor);
	avr_cycle_timer_register(m->avr, 1, board_after_reset_timer, m);
	ina219_start(&m->ina); /* the INA219 is not reset with the AVR; its timer was */
	pwm_ocr_fix_restart(&m->ocr_fix);
	if (m->has_pwm_model)
		pwm_model_restart(&m->pwm);
	m->feeding = 0;
	m->xoff = 0;
	if (m->has_boot)
		m->avr->pc = m->boot_addr; /* BOOTRST: start in the bootloader */
	m->foreign_reset = !m->own_reset;
}



void simmod_module_after_reset(module_t *m)
{
	m->reset_seen = 0;
	simmod_set_run_batching(m);
	extint_fix(m->avr);
	uint32_t flags = 0; /* no console echo, no polling sleep */
	avr_ioctl(m->avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
	simmod_uart_restart(m);
}

void simmod_module_reset(module_t *m, uint8_t mcusr)
{
	if (!m->alive)
		return;
	m->own_reset = 1;
	avr_reset(m->avr);
	m->own_reset = 0;
	m->avr->data[REG_MCUSR] = mcusr;
	simmod_module_after_reset(m);
}



/* ---- creation ---- */

static void module_free_fw(module_t *m)
{
	if (!m->fw)
		return;
	free(m->fw->flash);
	free(m->fw->eeprom);
	for (uint32_t i = 0; m->fw->symbol && i < m->fw->symbolcount; i++)
		free(m->fw->symbol[i]);
	free(m->fw->symbol);
	free(m->fw);
	m->fw = NULL;
}

static void module_free_avr(module_t *m)
{
	if (m->alive)
		avr_terminate(m->avr);
	free(m->avr);
	m->avr = NULL;
}

static module_t *module_create(simmod_t *sim, int index)
{
	const simmod_config_t *cfg = &sim->cfg;
	module_t *m = calloc(1, sizeof(*m));
	if (!m)
		return NULL;
	m->sim = sim;
	m->index = index;

	m->fw = calloc(1, sizeof(*m->fw));
	if (!m->fw || elf_read_firmware(cfg->elf_path, m->fw) != 0) {
		fprintf(stderr, "auger-sim: cannot read firmware %s\n", cfg->elf_path);
		module_free_fw(m);
		free(m);
		return NULL;
	}
	elf_firmware_t *fw = m->fw;
	const char *mmcu = fw->mmcu[0] ? fw->mmcu : "atmega328p";
	m->avr = avr_make_mcu_by_name(mmcu);
	if (!m->avr) {
		module_free_fw(m);
		free(m);
		return NULL;
	}
	avr_init(m->avr);
	extint_fix(m->avr); /* before any part drives a pin */
	avr_load_firmware(m->avr, fw);
	/* the code and EEPROM images are copied in; free them now */
	free(fw->flash);
	free(fw->eeprom);
	fw->flash = fw->eeprom = NULL;
	double f = fw->frequency ? fw->frequency : 16000000.0;
	m->avr->frequency = (uint32_t)llround(f * (1.0 + cfg->clock_offset_ppm[index] * 1e-6));
	m->freq_hz = m->avr->frequency;
	m->avr->sleep = sleep_count; /* batch or our own pacer: never simavr's usleep */
	m->avr->custom.data = m;     /* for sleep_count; custom.init/deinit stay NULL */
	m->alive = 1;

	uint32_t v;
	if (simmod_elf_symbol(cfg->elf_path, "__bss_end", &v) || simmod_elf_symbol(cfg->elf_path, "_end", &v)) {
		m->bss_end = v & 0xFFFF;
		m->has_bss_end = 1;
	}

	battery_init(&m->battery, &cfg->battery);
	motor_init(m->avr, &m->motor, &cfg->motor, &m->battery, cfg->physics_step_s);
	motor_set_hook(&m->motor, motor_step_to_parts, m);
	encoder_init(m->avr, &m->encoder, cfg->encoder_counts_per_rev);
	ina219_init(m->avr, &m->ina, cfg->ina219_addr7, cfg->shunt_ohm);

	/* docs/hardware.md: PWM PB1, DIR PB0, encoder A PD2, B PD3, INA219 on TWI */
	motor_attach(&m->motor, avr_io_getirq(m->avr, AVR_IOCTL_IOPORT_GETIRQ('B'), 1),
			avr_io_getirq(m->avr, AVR_IOCTL_IOPORT_GETIRQ('B'), 0));
	encoder_attach(&m->encoder, avr_io_getirq(m->avr, AVR_IOCTL_IOPORT_GETIRQ('D'), 2),
			avr_io_getirq(m->avr, AVR_IOCTL_IOPORT_GETIRQ('D'), 3));
	encoder_drive_port(&m->encoder, 'D', 2, 3);
	ina219_attach(&m->ina, 0);
	if (pwm_ocr_fix_attach(m->avr, &m->ocr_fix, '1', REG_TCCR1B) != 0)
		fprintf(stderr, "auger-sim: timer 1 not found, OCR1A writes may not reach PB1\n");
	if (!cfg->exact_pwm && pwm_model_attach(m->avr, &m->pwm) == 0) {
		m->has_pwm_model = 1;
		m->ocr_fix.bypass = &m->pwm.active; /* simavr's Timer1 is stopped meanwhile */
		motor_use_pwm_model(&m->motor, &m->pwm);
	}

	simmod_uart_attach(m);

	m->board_io.kind = "auger-board";
	m->board_io.reset = board_reset_hook;
	avr_register_io(m->avr, &m->board_io);

	if (cfg->bootloader_hex && cfg->bootloader_hex[0]) {
		uint32_t base = 0;
		if (simmod_load_ihex(cfg->bootloader_hex, m->avr->flash, m->avr->flashend + 1, &base) != 0) {
			fprintf(stderr, "auger-sim: cannot load bootloader %s\n", cfg->bootloader_hex);
			module_free_avr(m);
			module_free_fw(m);
			free(m);
			return NULL;
		}
		m->boot_addr = base;
		m->has_boot = 1;
		m->avr->reset_pc = base;
		m->avr->pc = base;
	}
	simmod_module_after_reset(m);
	/* power-on; with a bootloader, start as after an external reset so it waits for
	 * a host */
	m->avr->data[REG_MCUSR] = m->has_boot ? MCUSR_EXTRF : MCUSR_PORF;

	m->service_cycles = (avr_cycle_count_t)(SERVICE_PERIOD_S * m->freq_hz);
	m->next_service = m->avr->cycle + m->service_cycles;
	if (cfg->pty_dir && cfg->pty_dir[0]) {
		char link[512];
		snprintf(link, sizeof(link), "%s/module%d", cfg->pty_dir, index);
		if (pty_bridge_open(&m->pty, link) != 0) {
			fprintf(stderr, "auger-sim: cannot create a pty for module %d\n", index);
			module_free_avr(m);
			module_free_fw(m);
			free(m);
			return NULL;
		}
		m->has_pty = 1;
	}
	return m;
}

static void module_destroy(module_t *m)
{
	if (!m)
		return;
	if (m->has_pty)
		pty_bridge_close(&m->pty);
	avr_free_irq(m->motor.irq, IRQ_MOTOR_COUNT);
	avr_free_irq(m->encoder.irq, IRQ_ENCODER_COUNT);
	avr_free_irq(m->ina.irq, IRQ_INA219_COUNT);
	module_free_avr(m);
	module_free_fw(m);
	free(m->out);
	free(m);
}

/* ---- threads: each worker advances its share of the modules to the same target ---- */





/* ---- public API ---- */

void simmod_config_default(simmod_config_t *cfg)
{
	memset(cfg, 0, sizeof(*cfg));
	cfg->count = 1;
	cfg->threads = 0;
	cfg->physics_step_s = 100e-6;
	cfg->shunt_ohm = 0.01;
	cfg->ina219_addr7 = 0x40;
	cfg->encoder_counts_per_rev = 48;
	motor_params_default(&cfg->motor);
	battery_params_default(&cfg->battery);
}

simmod_t *simmod_create(const simmod_config_t *cfg)
{
	if (!cfg->elf_path || cfg->count < 1 || cfg->count > SIMMOD_MAX_MODULES) {
		fprintf(stderr, "auger-sim: bad configuration (elf path, count 1..%d)\n",
				SIMMOD_MAX_MODULES);
		return NULL;
	}
	simmod_t *sim = calloc(1, sizeof(*sim));
	if (!sim)
		return NULL;
	sim->cfg = *cfg;
	motor_params_derive(&sim->cfg.motor);
	log_level = cfg->verbose ? LOG_TRACE : LOG_ERROR;
	avr_global_logger_set(sim_logger);
	for (int i = 0; i < cfg->count; i++) {
		sim->mod[i] = module_create(sim, i);
		if (!sim->mod[i]) {
			sim->count = i;
			simmod_destroy(sim);
			return NULL;
		}
	}
	sim->count = cfg->count;

	int threads = cfg->threads;
	if (threads <= 0) {
		long cores = sysconf(_SC_NPROCESSORS_ONLN);
		threads = cores >= 2 ? 2 : 1;
	}
	if (threads > sim->count)
		threads = sim->count;
	simmod_threads_start(sim, threads);
	return sim;
}

void simmod_destroy(simmod_t *sim)
{
	if (!sim)
		return;
	simmod_threads_stop(sim);
	for (int i = 0; i < sim->count; i++)
		module_destroy(sim->mod[i]);
	free(sim);
}

int simmod_count(const simmod_t *sim)
{
	return sim->count;
}





int simmod_state(const simmod_t *sim, int module)
{
	return sim->mod[module]->alive ? 0 : -1;
}

double simmod_shaft_angle_rad(const simmod_t *sim, int module)
{
	return motor_model_out_angle_rad(&sim->mod[module]->motor.model);
}

double simmod_shaft_speed_rpm(const simmod_t *sim, int module)
{
	return motor_model_out_rpm(&sim->mod[module]->motor.model);
}

double simmod_motor_angle_rad(const simmod_t *sim, int module)
{
	return sim->mod[module]->motor.model.angle_rad;
}

double simmod_motor_current_a(const simmod_t *sim, int module)
{
	return sim->mod[module]->motor.model.current_a;
}

double simmod_battery_current_a(const simmod_t *sim, int module)
{
	return sim->mod[module]->motor.battery_current_a;
}

double simmod_battery_voltage_v(const simmod_t *sim, int module)
{
	const module_t *m = sim->mod[module];
	return battery_terminal_v(&m->battery, m->motor.battery_current_a);
}

double simmod_battery_charge_c(const simmod_t *sim, int module)
{
	return sim->mod[module]->battery.drawn_c;
}

double simmod_pwm_duty(const simmod_t *sim, int module)
{
	return motor_pwm_duty(&sim->mod[module]->motor);
}

double simmod_pwm_quiet_s(const simmod_t *sim, int module)
{
	return motor_pwm_quiet_s(&sim->mod[module]->motor);
}

int simmod_dir_pin(const simmod_t *sim, int module)
{
	return sim->mod[module]->motor.dir_level;
}

void simmod_set_load_torque(simmod_t *sim, int module, double torque_nm)
{
	motor_set_load(&sim->mod[module]->motor, torque_nm);
}

void simmod_set_battery_voltage(simmod_t *sim, int module, double v)
{
	battery_force_v(&sim->mod[module]->battery, v);
}

void simmod_set_battery_soc(simmod_t *sim, int module, double soc)
{
	battery_set_soc(&sim->mod[module]->battery, soc);
}

int64_t simmod_encoder_count(const simmod_t *sim, int module)
{
	return sim->mod[module]->encoder.count;
}

void simmod_ina219_glitch(simmod_t *sim, int module)
{
	ina219_power_on_reset(&sim->mod[module]->ina);
}

uint16_t simmod_ina219_register(const simmod_t *sim, int module, uint8_t reg)
{
	ina219_regs_t r = sim->mod[module]->ina.regs; /* a copy: reading power clears CNVR */
	return ina219_regs_read(&r, reg);
}

void simmod_lock_shaft(simmod_t *sim, int module, int locked)
{
	motor_model_t *mm = &sim->mod[module]->motor.model;
	mm->locked = locked != 0;
	if (mm->locked)
		mm->omega_rad_s = 0;
}

void simmod_set_load_viscous(simmod_t *sim, int module, double nm_per_rpm)
{
	sim->mod[module]->motor.model.load_viscous_nm_per_rpm = nm_per_rpm;
}



const char *simmod_pty_path(const simmod_t *sim, int module)
{
	const module_t *m = sim->mod[module];
	return m->has_pty ? m->pty.slave_path : "";
}

const char *simmod_pty_link(const simmod_t *sim, int module)
{
	const module_t *m = sim->mod[module];
	return m->has_pty ? m->pty.link_path : "";
}

void simmod_reset(simmod_t *sim, int module)
{
	simmod_module_reset(sim->mod[module], MCUSR_EXTRF);
}

void simmod_reset_as(simmod_t *sim, int module, uint8_t mcusr, int power_lost)
{
	module_t *m = sim->mod[module];
	if (power_lost && m->alive) {
		/* SRAM after a power loss holds no trace of the previous run */
		uint32_t x = 0x9E3779B9u;
		for (uint32_t a = m->avr->ioend + 1; a <= m->avr->ramend; a++) {
			x ^= x << 13;
			x ^= x >> 17;
			x ^= x << 5;
			m->avr->data[a] = (uint8_t)x;
		}
	}
	simmod_module_reset(m, mcusr);
}

static int eeprom_access(simmod_t *sim, int module, uint16_t addr, uint8_t *data, size_t len, uint32_t ioctl)
{
	avr_t *avr = sim->mod[module]->avr;
	if (len == 0 || (uint32_t)addr + len > (uint32_t)avr->e2end + 1)
		return -1;
	avr_eeprom_desc_t d = { data, addr, (uint32_t)len };
	avr_ioctl(avr, ioctl, &d); /* simavr 1.6 returns -1 for a successful GET */
	return 0;
}

int simmod_eeprom_write(simmod_t *sim, int module, uint16_t addr, const uint8_t *data, size_t len)
{
	return eeprom_access(sim, module, addr, (uint8_t *)(uintptr_t)data, len, AVR_IOCTL_EEPROM_SET);
}

int simmod_eeprom_read(simmod_t *sim, int module, uint16_t addr, uint8_t *data, size_t len)
{
	return eeprom_access(sim, module, addr, data, len, AVR_IOCTL_EEPROM_GET);
}

int simmod_stack_headroom(const simmod_t *sim, int module, uint8_t paint_byte)
{
	const module_t *m = sim->mod[module];
	if (!m->has_bss_end || !m->alive)
		return -1;
	const uint8_t *d = m->avr->data;
	uint32_t sp = d[REG_SPL] | ((uint32_t)d[REG_SPH] << 8);
	if (sp > m->avr->ramend)
		sp = m->avr->ramend;
	int best = 0, run = 0;
	for (uint32_t a = m->bss_end; a <= sp; a++) {
		run = d[a] == paint_byte ? run + 1 : 0;
		if (run > best)
			best = run;
	}
	return best;
}

void *simmod_avr(simmod_t *sim, int module)
{
	return sim->mod[module]->avr;
}

uint64_t simmod_cycles(const simmod_t *sim, int module)
{
	return sim->mod[module]->avr->cycle;
}

uint64_t simmod_sleep_cycles(const simmod_t *sim, int module)
{
	return sim->mod[module]->sleep_cycles;
}

struct encoder_t *simmod_encoder(simmod_t *sim, int module)
{
	return &sim->mod[module]->encoder;
}


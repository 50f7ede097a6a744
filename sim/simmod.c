/*
 * simmod: the board. Builds one simavr ATmega328P per module from the firmware ELF and
 * wires the parts to docs/hardware.md's pins; steps the modules in simulated time,
 * sequentially or on worker threads, batch or paced to the wall clock.
 */
#define _DEFAULT_SOURCE
#include "simmod.h"

#include <errno.h>
#include <fcntl.h>
#include <gelf.h>
#include <libelf.h>
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "avr_eeprom.h"
#include "avr_extint.h"
#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"
#include "sim_time.h"

#include "encoder.h"
#include "ina219.h"
#include "motor.h"
#include "pty_bridge.h"
#include "pwm_model.h"
#include "pwm_ocr_fix.h"

/* ATmega328P data-space addresses the board touches */
#define REG_MCUSR 0x54
#define REG_SPL 0x5D
#define REG_SPH 0x5E
#define REG_UCSR0A 0xC0
#define REG_UBRR0L 0xC4
#define REG_UBRR0H 0xC5
#define REG_TCCR1B 0x81
#define MCUSR_PORF 0x01
#define MCUSR_EXTRF 0x02
#define UCSR0A_U2X0 0x02
#define UART_BITS_PER_BYTE 11 /* simavr's framing: its RX delivers a byte per 11 bits */

#define IN_CAP 8192
#define SERVICE_PERIOD_S 1e-3
#define REALTIME_SLICE_S 1e-3

typedef struct out_byte_t {
	uint8_t byte;
	double t_s;
} out_byte_t;

typedef struct module_t {
	simmod_t *sim;
	int index;
	avr_t *avr;
	int alive;
	double freq_hz;
	avr_io_t board_io; /* only for its reset hook */
	int reset_seen;
	int own_reset, foreign_reset;

	battery_t battery;
	motor_t motor;
	encoder_t encoder;
	ina219_t ina;
	pwm_ocr_fix_t ocr_fix;
	pwm_model_t pwm;
	int has_pwm_model;

	avr_irq_t *uart_irq;
	uint8_t in_buf[IN_CAP];
	size_t in_head, in_len;
	int feeding, xoff, xoff_ticks;
	out_byte_t *out;
	size_t out_len, out_cap;
	uint8_t pty_out[4096];
	size_t pty_out_len;
	pty_bridge_t pty;
	int has_pty;
	avr_cycle_count_t next_service, service_cycles;

	uint32_t bss_end;
	int has_bss_end;
	uint32_t boot_addr;
	int has_boot;
	uint64_t sleep_cycles; /* cycles simavr skipped while the AVR slept (CPU load) */
	simmod_step_hook_t step_hook;
	void *step_hook_ctx;
	elf_firmware_t *fw; /* kept: simavr may point into its symbol table */
} module_t;

typedef struct worker_arg_t {
	struct simmod_t *sim;
	int w;
} worker_arg_t;

struct simmod_t {
	simmod_config_t cfg;
	int count;
	module_t *mod[SIMMOD_MAX_MODULES];
	double t_s;
	simmod_uart_cb_t cb;
	void *cb_ctx;

	int nthreads;
	pthread_t th[SIMMOD_MAX_MODULES];
	worker_arg_t args[SIMMOD_MAX_MODULES];
	pthread_mutex_t mu;
	pthread_cond_t go, done;
	unsigned gen;
	int busy, quit;
	double target_s;

	int wall_started;
	struct timespec wall0;
};

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

/* ---- ELF symbols (for the stack painting read-back) ---- */

static int elf_find_symbol(const char *path, const char *name, uint32_t *value)
{
	int found = 0;
	if (elf_version(EV_CURRENT) == EV_NONE)
		return 0;
	int fd = open(path, O_RDONLY);
	if (fd < 0)
		return 0;
	Elf *elf = elf_begin(fd, ELF_C_READ, NULL);
	Elf_Scn *scn = NULL;
	while (elf && !found && (scn = elf_nextscn(elf, scn)) != NULL) {
		GElf_Shdr sh;
		if (!gelf_getshdr(scn, &sh) || sh.sh_type != SHT_SYMTAB)
			continue;
		Elf_Data *data = elf_getdata(scn, NULL);
		size_t n = sh.sh_entsize ? sh.sh_size / sh.sh_entsize : 0;
		for (size_t i = 0; data && i < n; i++) {
			GElf_Sym sym;
			if (!gelf_getsym(data, (int)i, &sym))
				continue;
			const char *s = elf_strptr(elf, sh.sh_link, sym.st_name);
			if (s && strcmp(s, name) == 0) {
				*value = (uint32_t)sym.st_value;
				found = 1;
				break;
			}
		}
	}
	if (elf)
		elf_end(elf);
	close(fd);
	return found;
}

/* ---- Intel HEX (simavr 1.6's reader rejects Optiboot's type 03 record) ---- */

static int hex_byte(const char *s)
{
	int v = 0;
	for (int i = 0; i < 2; i++) {
		char c = s[i];
		int d = c >= '0' && c <= '9' ? c - '0' : c >= 'A' && c <= 'F' ? c - 'A' + 10 :
				c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
		if (d < 0)
			return -1;
		v = v * 16 + d;
	}
	return v;
}

/* Load data records into flash; *lowest gets the lowest address written. 0 or -1. */
static int load_ihex(const char *path, uint8_t *flash, uint32_t flash_size, uint32_t *lowest)
{
	FILE *f = fopen(path, "r");
	if (!f)
		return -1;
	char line[600];
	uint32_t base = 0;
	int ok = 0, any = 0;
	*lowest = flash_size;
	while (fgets(line, sizeof(line), f)) {
		if (line[0] != ':')
			continue;
		int n = hex_byte(line + 1), ah = hex_byte(line + 3), al = hex_byte(line + 5),
				type = hex_byte(line + 7);
		if (n < 0 || ah < 0 || al < 0 || type < 0 || strlen(line) < (size_t)(11 + 2 * n))
			break;
		int sum = n + ah + al + type;
		uint8_t data[256];
		for (int i = 0; i < n; i++) {
			int b = hex_byte(line + 9 + 2 * i);
			if (b < 0)
				goto done;
			data[i] = (uint8_t)b;
			sum += b;
		}
		int check = hex_byte(line + 9 + 2 * n);
		if (check < 0 || ((sum + check) & 0xFF) != 0)
			break;
		if (type == 0) {
			uint32_t addr = base + (uint32_t)((ah << 8) | al);
			if (addr + (uint32_t)n > flash_size) {
				/* Debian's optiboot_atmega328.hex has 20 bytes past 32 KiB: the chip
				 * has no such flash, drop them */
				fprintf(stderr, "auger-sim: %s: %d bytes at 0x%05x are beyond flash, ignored\n",
						path, n, (unsigned)addr);
				continue;
			}
			memcpy(flash + addr, data, (size_t)n);
			if (addr < *lowest)
				*lowest = addr;
			any = 1;
		} else if (type == 1) {
			ok = any;
			break;
		} else if (type == 2 && n == 2) {
			base = (uint32_t)((data[0] << 8) | data[1]) << 4;
		} else if (type == 4 && n == 2) {
			base = (uint32_t)((data[0] << 8) | data[1]) << 16;
		} /* 3 and 5: start addresses, meaningless for an AVR */
	}
done:
	fclose(f);
	return ok ? 0 : -1;
}

/* ---- UART ---- */

static avr_cycle_count_t uart_byte_cycles(const module_t *m)
{
	const uint8_t *d = m->avr->data;
	uint32_t ubrr = d[REG_UBRR0L] | ((uint32_t)(d[REG_UBRR0H] & 0x0F) << 8);
	uint32_t per_bit = (ubrr + 1) * ((d[REG_UCSR0A] & UCSR0A_U2X0) ? 8u : 16u);
	return (avr_cycle_count_t)per_bit * UART_BITS_PER_BYTE;
}

static avr_cycle_count_t uart_feed_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	module_t *m = (module_t *)param;
	if (!m->in_len) {
		m->feeding = 0;
		return 0;
	}
	/* Hold while simavr's 63-byte FIFO is full. It signals room (XON) only when the
	 * firmware polls UCSR0A with the FIFO empty, so give up waiting after 64 byte times:
	 * by then a firmware that reads at all has drained it. */
	if (m->xoff && ++m->xoff_ticks < 64)
		return when + uart_byte_cycles(m);
	m->xoff = 0;
	m->xoff_ticks = 0;
	uint8_t b = m->in_buf[m->in_head];
	m->in_head = (m->in_head + 1) % IN_CAP;
	m->in_len--;
	avr_raise_irq(m->uart_irq + UART_IRQ_INPUT, b);
	return when + uart_byte_cycles(m);
}

static void uart_queue(module_t *m, const uint8_t *data, size_t len)
{
	for (size_t i = 0; i < len && m->in_len < IN_CAP; i++) {
		m->in_buf[(m->in_head + m->in_len) % IN_CAP] = data[i];
		m->in_len++;
	}
	if (m->in_len && !m->feeding && m->alive) {
		m->feeding = 1;
		avr_cycle_timer_register(m->avr, 1, uart_feed_timer, m);
	}
}

static void uart_out_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	module_t *m = (module_t *)param;
	if (m->out_len == m->out_cap) {
		size_t cap = m->out_cap ? 2 * m->out_cap : 256;
		out_byte_t *o = realloc(m->out, cap * sizeof(*o));
		if (!o)
			return;
		m->out = o;
		m->out_cap = cap;
	}
	m->out[m->out_len].byte = (uint8_t)value;
	m->out[m->out_len].t_s = (double)m->avr->cycle / m->freq_hz;
	m->out_len++;
	if (m->has_pty) {
		if (m->pty_out_len == sizeof(m->pty_out)) {
			pty_bridge_write(&m->pty, m->pty_out, m->pty_out_len);
			m->pty_out_len = 0;
		}
		m->pty_out[m->pty_out_len++] = (uint8_t)value;
	}
}

static void uart_xon_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	(void)value;
	module_t *m = (module_t *)param;
	m->xoff = 0;
	m->xoff_ticks = 0;
}

static void uart_xoff_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	module_t *m = (module_t *)param;
	m->xoff = value != 0;
	m->xoff_ticks = 0;
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

/* simavr 1.6 runs one instruction per avr_run unless run_cycle_limit allows more: then
 * avr_run_one goes on until the next cycle timer (avr_cycle_timer_register shortens the run
 * when an instruction schedules an earlier one), an interrupt or a sleep. The simulation is
 * the same instruction for instruction (module_advance puts a timer at every time it stops
 * at); the per-instruction round of timer checks and calls goes. A profiler's step hook
 * wants every instruction: then one at a time. avr_reset sets the limit back to 1. */
static void set_run_batching(module_t *m)
{
	m->avr->run_cycle_limit = m->step_hook ? 1 : (avr_cycle_count_t)1 << 24;
}

/* A timer that does nothing: it ends an instruction run at a time the board stops at. */
static avr_cycle_count_t fence_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	(void)when;
	(void)param;
	return 0;
}

static void module_after_reset(module_t *m)
{
	m->reset_seen = 0;
	set_run_batching(m);
	extint_fix(m->avr);
	uint32_t flags = 0; /* no console echo, no polling sleep */
	avr_ioctl(m->avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
	if (m->in_len && m->alive) {
		m->feeding = 1;
		avr_cycle_timer_register(m->avr, 1, uart_feed_timer, m);
	}
}

static void module_reset(module_t *m, uint8_t mcusr)
{
	if (!m->alive)
		return;
	m->own_reset = 1;
	avr_reset(m->avr);
	m->own_reset = 0;
	m->avr->data[REG_MCUSR] = mcusr;
	module_after_reset(m);
}

static void module_service(module_t *m)
{
	if (!m->has_pty)
		return;
	if (m->pty_out_len) {
		pty_bridge_write(&m->pty, m->pty_out, m->pty_out_len);
		m->pty_out_len = 0;
	}
	if (pty_bridge_poll_open(&m->pty) && m->sim->cfg.reset_on_open)
		module_reset(m, MCUSR_EXTRF);
	uint8_t buf[256];
	size_t n = pty_bridge_read(&m->pty, buf, sizeof(buf));
	if (n)
		uart_queue(m, buf, n);
}

static void module_advance(module_t *m, double t_s)
{
	avr_t *avr = m->avr;
	avr_cycle_count_t target = (avr_cycle_count_t)(t_s * m->freq_hz);
	while (m->alive && avr->cycle < target) {
		avr_cycle_count_t stop = target < m->next_service ? target : m->next_service;
		avr_cycle_timer_register(avr, stop - avr->cycle, fence_timer, m);
		while (avr->cycle < stop) {
			if (m->step_hook) {
				simmod_step_info_t info;
				info.pc_before = avr->pc;
				info.cycle_before = avr->cycle;
				uint64_t slept = m->sleep_cycles;
				avr_run(avr);
				info.pc_after = avr->pc;
				info.cycle_after = avr->cycle;
				info.sleep_cycles = m->sleep_cycles - slept;
				info.sp_after = (uint16_t)(avr->data[REG_SPL] | (avr->data[REG_SPH] << 8));
				m->step_hook(m->step_hook_ctx, m->index, &info);
			} else {
				avr_run(avr);
			}
			int state = avr->state;
			if (state == cpu_Done || state == cpu_Crashed) {
				m->alive = 0;
				fprintf(stderr, "auger-sim: module %d stopped (%s) at %.6f s\n", m->index,
						state == cpu_Done ? "slept with interrupts off" : "crashed",
						(double)avr->cycle / m->freq_hz);
				return;
			}
			if (m->reset_seen) {
				module_after_reset(m);
				/* A watchdog reset (Optiboot's way to start the application) leaves
				 * simavr 1.6's watchdog enabled, so the application would be reset again
				 * and again: with a bootloader, redo it as a power-on reset. */
				if (m->foreign_reset && m->has_boot)
					module_reset(m, MCUSR_PORF);
			}
		}
		if (avr->cycle >= m->next_service) {
			module_service(m);
			m->next_service += m->service_cycles;
		}
	}
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
	if (elf_find_symbol(cfg->elf_path, "__bss_end", &v) || elf_find_symbol(cfg->elf_path, "_end", &v)) {
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

	m->uart_irq = avr_io_getirq(m->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
	avr_irq_register_notify(m->uart_irq + UART_IRQ_OUTPUT, uart_out_hook, m);
	avr_irq_register_notify(m->uart_irq + UART_IRQ_OUT_XON, uart_xon_hook, m);
	avr_irq_register_notify(m->uart_irq + UART_IRQ_OUT_XOFF, uart_xoff_hook, m);

	m->board_io.kind = "auger-board";
	m->board_io.reset = board_reset_hook;
	avr_register_io(m->avr, &m->board_io);

	if (cfg->bootloader_hex && cfg->bootloader_hex[0]) {
		uint32_t base = 0;
		if (load_ihex(cfg->bootloader_hex, m->avr->flash, m->avr->flashend + 1, &base) != 0) {
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
	module_after_reset(m);
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


static void advance_share(simmod_t *sim, int w, double t_s)
{
	for (int i = w; i < sim->count; i += sim->nthreads)
		module_advance(sim->mod[i], t_s);
}

static void *worker_main(void *arg)
{
	worker_arg_t *a = (worker_arg_t *)arg;
	simmod_t *sim = a->sim;
	unsigned seen = 0;
	pthread_mutex_lock(&sim->mu);
	for (;;) {
		while (sim->gen == seen && !sim->quit)
			pthread_cond_wait(&sim->go, &sim->mu);
		if (sim->quit)
			break;
		seen = sim->gen;
		double t = sim->target_s;
		pthread_mutex_unlock(&sim->mu);
		advance_share(sim, a->w, t);
		pthread_mutex_lock(&sim->mu);
		if (--sim->busy == 0)
			pthread_cond_signal(&sim->done);
	}
	pthread_mutex_unlock(&sim->mu);
	return NULL;
}

static void advance_all(simmod_t *sim, double t_s)
{
	if (sim->nthreads <= 1) {
		advance_share(sim, 0, t_s);
		return;
	}
	pthread_mutex_lock(&sim->mu);
	sim->target_s = t_s;
	sim->busy = sim->nthreads - 1;
	sim->gen++;
	pthread_cond_broadcast(&sim->go);
	pthread_mutex_unlock(&sim->mu);
	advance_share(sim, 0, t_s);
	pthread_mutex_lock(&sim->mu);
	while (sim->busy)
		pthread_cond_wait(&sim->done, &sim->mu);
	pthread_mutex_unlock(&sim->mu);
}

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
	sim->nthreads = threads;
	pthread_mutex_init(&sim->mu, NULL);
	pthread_cond_init(&sim->go, NULL);
	pthread_cond_init(&sim->done, NULL);
	for (int w = 1; w < sim->nthreads; w++) {
		worker_arg_t *a = &sim->args[w];
		a->sim = sim;
		a->w = w;
		if (pthread_create(&sim->th[w], NULL, worker_main, a) != 0) {
			sim->nthreads = w;
			break;
		}
	}
	return sim;
}

void simmod_destroy(simmod_t *sim)
{
	if (!sim)
		return;
	if (sim->nthreads > 1) {
		pthread_mutex_lock(&sim->mu);
		sim->quit = 1;
		pthread_cond_broadcast(&sim->go);
		pthread_mutex_unlock(&sim->mu);
		for (int w = 1; w < sim->nthreads; w++)
			pthread_join(sim->th[w], NULL);
	}
	for (int i = 0; i < sim->count; i++)
		module_destroy(sim->mod[i]);
	free(sim);
}

int simmod_count(const simmod_t *sim)
{
	return sim->count;
}

static void dispatch_uart(simmod_t *sim)
{
	for (int i = 0; i < sim->count; i++) {
		module_t *m = sim->mod[i];
		if (sim->cb)
			for (size_t k = 0; k < m->out_len; k++)
				sim->cb(sim->cb_ctx, i, m->out[k].byte, m->out[k].t_s);
		m->out_len = 0;
	}
}

static double wall_since(const struct timespec *t0)
{
	struct timespec now;
	clock_gettime(CLOCK_MONOTONIC, &now);
	return (double)(now.tv_sec - t0->tv_sec) + 1e-9 * (double)(now.tv_nsec - t0->tv_nsec);
}

void simmod_step_to(simmod_t *sim, double t_s)
{
	if (t_s <= sim->t_s)
		return;
	if (!sim->cfg.realtime) {
		advance_all(sim, t_s);
		sim->t_s = t_s;
		dispatch_uart(sim);
		return;
	}
	if (!sim->wall_started) {
		clock_gettime(CLOCK_MONOTONIC, &sim->wall0);
		sim->wall0.tv_sec -= (time_t)sim->t_s; /* keep sim time and wall time aligned */
		sim->wall_started = 1;
	}
	while (sim->t_s < t_s) {
		double next = sim->t_s + REALTIME_SLICE_S;
		if (next > t_s)
			next = t_s;
		advance_all(sim, next);
		sim->t_s = next;
		dispatch_uart(sim);
		double ahead = next - wall_since(&sim->wall0);
		if (ahead > 0) {
			struct timespec d = { (time_t)ahead, (long)((ahead - floor(ahead)) * 1e9) };
			nanosleep(&d, NULL);
		}
	}
}

double simmod_time_s(const simmod_t *sim)
{
	return sim->t_s;
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

void simmod_set_uart_callback(simmod_t *sim, simmod_uart_cb_t cb, void *ctx)
{
	sim->cb = cb;
	sim->cb_ctx = ctx;
}

int simmod_uart_send(simmod_t *sim, int module, const uint8_t *data, size_t len)
{
	uart_queue(sim->mod[module], data, len);
	return 0;
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
	module_reset(sim->mod[module], MCUSR_EXTRF);
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
	module_reset(m, mcusr);
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

void simmod_force_encoder_rate(simmod_t *sim, int module, double edges_per_s, double jitter,
		uint64_t seed)
{
	module_t *m = sim->mod[module];
	encoder_force_rate(&m->encoder, edges_per_s, jitter, seed, m->motor.model.angle_rad);
}

void simmod_set_step_hook(simmod_t *sim, int module, simmod_step_hook_t hook, void *ctx)
{
	module_t *m = sim->mod[module];
	m->step_hook = hook;
	m->step_hook_ctx = ctx;
	set_run_batching(m);
}

/*
 * simmod's internals, shared by its files (not for its users: simmod.h is the API):
 * simmod.c the board (parts, resets, creation, accessors), simmod_load.c the ELF symbol and
 * Intel HEX loaders, simmod_uart.c the UART pump (and the pty), simmod_run.c running the
 * modules (instruction batching, worker threads, pacing to the wall clock).
 */
#ifndef AUGER_SIM_SIMMOD_INTERNAL_H
#define AUGER_SIM_SIMMOD_INTERNAL_H

#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <time.h>

#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"

#include "battery.h"
#include "encoder.h"
#include "ina219.h"
#include "motor.h"
#include "pty_bridge.h"
#include "pwm_model.h"
#include "pwm_ocr_fix.h"
#include "simmod.h"

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

/* ---- simmod.c: the board ---- */
/* Resets the AVR as the board would (mcusr: the reset cause the firmware sees). */
void simmod_module_reset(module_t *m, uint8_t mcusr);
/* After any reset of the AVR: batching, the INT0/INT1 fix, the UART flags, the feed. */
void simmod_module_after_reset(module_t *m);

/* ---- simmod_load.c ---- */
/* The value of an ELF symbol (e.g. __bss_end); 1 if found. */
int simmod_elf_symbol(const char *path, const char *name, uint32_t *value);
/* Intel HEX data records into flash; *lowest gets the lowest address written. 0 or -1. */
int simmod_load_ihex(const char *path, uint8_t *flash, uint32_t flash_size, uint32_t *lowest);

/* ---- simmod_uart.c ---- */
/* Wires the module's UART 0 to the pump (output bytes, XON/XOFF). */
void simmod_uart_attach(module_t *m);
/* Starts feeding queued input again (after a reset cleared the cycle timers). */
void simmod_uart_restart(module_t *m);
void simmod_uart_queue(module_t *m, const uint8_t *data, size_t len);
/* Every SERVICE_PERIOD_S: the pty's output flushed, its input queued, a reset on open. */
void simmod_uart_service(module_t *m);
/* Hands every module's output bytes to the callback (the caller's thread, end of a step). */
void simmod_uart_dispatch(simmod_t *sim);

/* ---- simmod_run.c ---- */
void simmod_set_run_batching(module_t *m);
/* Worker threads (sim->nthreads - 1 besides the caller's) started and stopped. */
void simmod_threads_start(simmod_t *sim, int threads);
void simmod_threads_stop(simmod_t *sim);

#endif
